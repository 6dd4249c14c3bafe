//! The real steps a closed-loop experiment ([`super::tune`], [`super::judge`]) compares a twin's
//! runs with, checked before the first run: the twin is of the log's robot, and the steps used
//! are enough for an interval.

use crate::error::{Error, Result};
use drive_sim_analysis::bootstrap::MIN_STEPS_FOR_INTERVAL;
use drive_sim_calibration::ModelParams;
use drive_sim_log::{DriveLog, UseSteps};

/// Refuses a twin of another robot than the real log's (bad input on `--robot`); `verb` says
/// what the twin is for ("tuned", "judged").
pub fn check_same_robot(real: &DriveLog, model: &ModelParams, verb: &str) -> Result<()> {
    if real.meta.robot == model.robot.name {
        return Ok(());
    }
    Err(Error::config(
        "--robot",
        &model.robot.name,
        format!(
            "the real log `{}` is of robot `{}`: a twin is {verb} against its own robot's log",
            real.meta.name, real.meta.robot
        ),
    ))
}

/// Some of a real log's steps, with how many of them the analysis keeps.
#[derive(Debug, Clone)]
pub struct RealSteps {
    /// Which steps.
    pub steps: UseSteps,
    /// The log holding only them.
    pub log: DriveLog,
    /// Analysed steps among them.
    pub analysed: usize,
}

/// The steps `steps` of `real`, refused (bad input on `flag`) when the analysis keeps fewer
/// than [`MIN_STEPS_FOR_INTERVAL`] of them; `purpose` says what they were for ("tune on").
pub fn real_steps(real: &DriveLog, steps: UseSteps, flag: &str, purpose: &str) -> Result<RealSteps> {
    let log = steps.select(real);
    let analysed = crate::analysis_of(&log)?.steps.len();
    if analysed < MIN_STEPS_FOR_INTERVAL {
        return Err(Error::config(
            flag,
            steps.as_str(),
            format!(
                "`{}` has {analysed} analysed steps there (fewer than {MIN_STEPS_FOR_INTERVAL}): no interval, nothing to {purpose}",
                real.meta.name
            ),
        ));
    }
    Ok(RealSteps { steps, log, analysed })
}

/// Refuses a number of DRIVE steps per simulated run (`--steps`) too small for an interval or
/// beyond any run's size; `None` (as many as the real steps) passes.
pub fn check_run_steps(steps: Option<u32>) -> Result<()> {
    match steps.filter(|s| (*s as usize) < MIN_STEPS_FOR_INTERVAL || *s > 100_000) {
        Some(s) => Err(Error::config(
            "<command line>",
            "--steps",
            format!("must be in {MIN_STEPS_FOR_INTERVAL}..=100000 (fewer give no interval), got {s}"),
        )),
        None => Ok(()),
    }
}
