//! The robot against itself: another real run of the same robot on the same ground, compared
//! with the judged real steps exactly as each of the twin's runs is.
//!
//! A twin cannot be asked to be closer to a run than the robot is to its own other runs. The
//! other run's comparison gives that distance in the judge's own currency (compare's loss and
//! verdict), beside the twin's runs' mean loss against the same steps: a twin whose mean loss
//! is at most the other run's is as close to this run as the robot itself was on another day.

use super::JudgeOptions;
use crate::error::{Error, Result};
use crate::real_steps::real_steps;
use crate::{compare, Input, MetricDiff};
use drive_sim_log::DriveLog;
use serde::{Deserialize, Serialize};

/// Another real run compared with the judged steps (`judge.json` → `yardsticks`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Yardstick {
    /// The other run's dataset name.
    pub other: String,
    /// Its analysed steps (all of them are compared).
    pub other_steps_analysed: usize,
    /// Compare's loss of the other run against the judged steps (the same loss the judge
    /// averages over the twin's runs); `None` when it could not be formed.
    pub loss: Option<f64>,
    /// Compare's verdict on the other run: it reproduces the judged steps.
    pub reproduces: bool,
    /// The medians whose difference is significant (Holm), the areas beyond tolerance and
    /// the maps beyond their yardstick, as the verdict lists them.
    pub differs_on: Vec<String>,
    /// The medians (ρ and the slips): other − judged, with Holm-adjusted p-values.
    pub medians: Vec<MetricDiff>,
    /// The twin's runs' mean loss against the same steps (the judge's `loss.real`).
    pub twin_mean_loss: f64,
    /// The twin is at least as close to the judged steps as the other real run:
    /// `twin_mean_loss <= loss`.
    pub twin_within: bool,
}

/// Compares `other` (all its steps) with the steps of `real` the options judge, with the
/// judge's compare options; `twin_mean_loss` is the judge's `loss.real`. Another robot or
/// another ground is bad input naming the other run.
pub fn yardstick(
    real: &DriveLog,
    other: &DriveLog,
    opts: &JudgeOptions,
    twin_mean_loss: f64,
) -> Result<Yardstick> {
    check_same_ground(real, other)?;
    let judged = real_steps(real, opts.real_steps, "--real-steps", "judge against")?;
    let all = real_steps(other, drive_sim_log::UseSteps::All, "--other-run", "compare with")?;
    let report = compare(
        Input {
            log: &judged.log,
            file: None,
        },
        &[Input {
            log: &all.log,
            file: None,
        }],
        &opts.compare_options(),
    )?;
    let c = &report.sims[0];
    let v = &c.verdict;
    let loss = c.loss.as_ref().map(|l| l.total);
    let differs_on = v
        .significant
        .iter()
        .cloned()
        .chain(
            v.areas_beyond_tolerance
                .iter()
                .map(|a| format!("{a} > tolerance")),
        )
        .chain(v.tf_beyond_yardstick.iter().map(|t| format!("{t} map")))
        .collect();
    Ok(Yardstick {
        other: other.meta.name.clone(),
        other_steps_analysed: all.analysed,
        loss,
        reproduces: v.reproduces,
        differs_on,
        medians: c
            .metrics
            .iter()
            .filter(|m| m.tolerance.is_none())
            .cloned()
            .collect(),
        twin_mean_loss,
        twin_within: loss.is_some_and(|l| twin_mean_loss <= l),
    })
}

/// Refuses a yardstick run of another robot or another ground (bad input naming it).
pub fn check_same_ground(real: &DriveLog, other: &DriveLog) -> Result<()> {
    let (r, o) = (&real.meta, &other.meta);
    if r.robot != o.robot || r.terrain != o.terrain {
        return Err(Error::config(
            "--other-run",
            &o.name,
            format!(
                "is of robot `{}` on `{}`, the judged run `{}` of `{}` on `{}`: the robot's own difference is measured on the same robot and ground",
                o.robot, o.terrain, r.name, r.robot, r.terrain
            ),
        ));
    }
    Ok(())
}
