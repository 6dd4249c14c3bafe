//! The calibration as stages, each a function from one input struct to one output struct:
//!
//! 1. [`baseline`]: the IDD and the declared model on the validation and test steps, and the
//!    base (terrain / robot) fit on the training steps, kept if it lowers the validation
//!    score;
//! 2. [`screening`]: with the simulator as the model, every candidate the kinematic model can
//!    represent is fitted and ranked with it first (milliseconds per fit); only the best few,
//!    and the contact effects it cannot represent, go on to the simulator;
//! 3. [`candidates`]: each candidate fitted on the training steps on top of the current model,
//!    judged by its validation-score reduction with a bootstrap standard error over steps and
//!    by the identifiability of its parameters;
//! 4. [`selection`]: forward selection, then pairs among the top candidates, then a backward
//!    pass that drops any effect whose removal does not hurt the validation score;
//! 5. [`discovery`] (with `discover`): equations fitted on what the selected model leaves, tried
//!    as model terms; when a channel is still flagged after it, discovery also runs from the
//!    base model, and the better of the two orders is kept ([`competition`]: one
//!    competition between the catalogue and the terms, the fewer parameters within one
//!    standard error);
//! 6. [`final_fit`]: the base and effect parameters refitted together, with their covariance;
//! 7. [`report`]: every reported score on the test steps, which nothing above touched.
//!
//! [`Context`] holds what every stage reads: the split, the step sets, the noise floor and
//! the command reach estimated on the training steps, the plant factory and the options.

pub mod baseline;
pub mod candidates;
pub mod competition;
pub mod discovery;
pub mod final_fit;
mod proposals;
mod reading;
pub mod report;
pub mod screening;
pub mod selection;

use super::data::{Split, StepSet};
use super::metrics::NoiseFloor;
use super::model::{ModelParams, PlantFactory};
use super::replay::ReplayCounters;
use super::CalibrationOptions;
use crate::events::CalibrationEvent;
use drive_sim_log::DriveLog;
use drive_sim_model::effects::CommandReach;
use serde::{Deserialize, Serialize};
use std::time::Instant;

/// What every stage reads.
pub struct Context<'a> {
    /// The log calibrated on.
    pub log: &'a DriveLog,
    /// The model's plants.
    pub factory: &'a dyn PlantFactory,
    /// Options.
    pub opts: &'a CalibrationOptions,
    /// Steps the analysis excludes (not in any set), with why.
    pub excluded: Vec<drive_sim_analysis::segment::Exclusion>,
    /// Which steps are for what.
    pub split: Split,
    /// Training steps: fits and estimates from data.
    pub train: StepSet<'a>,
    /// Validation steps: choices between models.
    pub validation: StepSet<'a>,
    /// Test steps: the reported scores only.
    pub test: StepSet<'a>,
    /// Noise floor, estimated on the training steps.
    pub floor: NoiseFloor,
    /// How far the training steps' commands reach (search boxes of limits).
    pub reach: CommandReach,
    /// The declared model (robot and terrain files, no effect).
    pub declared: ModelParams,
    /// Tells the user what a stage found as it ends.
    pub progress: &'a (dyn Fn(&CalibrationEvent) + Sync),
}

/// Wall time and replays of one stage.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StageTiming {
    /// Stage name.
    pub stage: String,
    /// Wall time, s.
    pub wall_s: f64,
    /// Steps replayed.
    pub steps_replayed: u64,
    /// Plants (simulator worlds) built.
    pub plants_built: u64,
}

/// Per-stage counters, like rapier's: written to `timings.json` beside `calibration.json`
/// (which stays byte-identical for a seed, so holds no time).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Timings {
    /// Stages in the order they ran.
    pub stages: Vec<StageTiming>,
    /// Total wall time, s.
    pub total_s: f64,
}

impl Timings {
    /// Runs `f` as the stage `name`, recording its time and replays.
    pub fn time<T>(&mut self, name: &str, f: impl FnOnce() -> T) -> T {
        let (t0, c0) = (Instant::now(), ReplayCounters::now());
        let out = f();
        let c = ReplayCounters::now().since(c0);
        let wall_s = t0.elapsed().as_secs_f64();
        self.total_s += wall_s;
        self.stages.push(StageTiming {
            stage: name.to_string(),
            wall_s,
            steps_replayed: c.steps,
            plants_built: c.plants,
        });
        out
    }

    /// One line per stage, for the terminal.
    pub fn lines(&self) -> Vec<String> {
        let mut v: Vec<String> = self
            .stages
            .iter()
            .map(|s| {
                format!(
                    "{:<12} {:>8.2} s  {:>7} steps replayed  {:>6} worlds built",
                    s.stage, s.wall_s, s.steps_replayed, s.plants_built
                )
            })
            .collect();
        v.push(format!("{:<12} {:>8.2} s", "total", self.total_s));
        v
    }
}
