//! Tuning a twin in closed loop: effect parameters chosen by what `compare` says about the
//! twin's own DRIVE runs against the real run, not by replays of the real commands.
//!
//! Calibration replays the measured commands and fits what it sees sample by sample; `compare`
//! judges a twin by its own DRIVE runs, in the paper's statistics (median ρ and slips, T/U
//! areas, transfer-function maps). The two views can disagree: on `warthog_asphalt` the
//! motor's torque-speed line is rejected by replays (its two ends are not identifiable there)
//! and explains most of the closed-loop gap (README, "Twins and compare"). This stage chooses
//! parameters by the closed-loop view, honestly:
//!
//! 1. **Choose** on the steps `choose_on` (odd, even or all) of the real log, with the seeds
//!    `seed + i` (`choose_seeds` of them, every point run with the same ones): the loss of
//!    [`crate::loss`] (each term 1 at its verdict's threshold), averaged over the seeds, minimised by a design over the box and
//!    a Nelder–Mead simplex ([`search`]).
//! 2. **Check** the choice on fresh seeds (`seed + 1000 + i`, `check_seeds` of them), same
//!    steps: the start and the chosen model, paired by seed. The choice is accepted when its
//!    mean loss reduction exceeds twice its standard error (a choice that only fitted its seeds'
//!    paths does not survive new ones). Otherwise the twin stays the start.
//! 3. **Judge** on the other half of the steps (when the choice used one half), which played no
//!    part in 1 or 2, with seeds `seed + 2000 + i`: both models' full comparisons and verdicts,
//!    whatever step 2 decided, beside the real choosing half itself judged the same way (how
//!    close a model matching it exactly could come). With `choose_on = all` there is nothing
//!    left out: the judgement is on the same steps with those seeds (`same_steps`, not held
//!    out), and the outcome says so.
//!
//! Runs have as many DRIVE steps as the real steps they are compared with unless told
//! otherwise: a T/U area is a hull, which grows with the number of steps.
//!
//! Each run is the DRIVE protocol of `drive-sim run --robot twin/robot.toml --terrain
//! twin/terrain.toml --steps N --seed S` (typical sensor noise), held in memory, with one
//! difference: its commands are drawn as the real steps it is compared with were, each step
//! uniformly in U inside the quadrant (forward or backward, turning left or right) of the real
//! step's command ([`twin_run_matched`]). A run's medians are its quadrants' mix: the paper's
//! uniform draws give 50 left turns in 100 give or take 5, `warthog_asphalt` drew 36 in 98, and a
//! twin tuned by uniform draws to its median yaw slip would carry the draw's luck as physics.

mod choose;
mod event;
mod judging;
mod outcome;
mod params;
mod runs;
pub mod search;
pub mod write;

use choose::{choose, LossRuns, Space};
pub use event::TuneEvent;
use judging::Judging;
pub use outcome::{check_rule, HeldOut, JudgedRun, PointEvaluation, SeedCheck, TuneOutcome, TunedParam};
pub use params::{apply_boxes, tuned_specs, BoxOverride};
use runs::loss_opts;
pub use runs::{run_loss, search_compare_options, twin_run, twin_run_matched};
pub use write::twin_of;

use crate::error::{Error, Result};
use crate::loss::Loss;
use crate::real_steps::{check_run_steps, check_same_robot, real_steps};
use crate::{
    compare_prepared, CompareOptions, ComparisonReport, Input, MetricDiff, PreparedReal, TfDiff, TfSmoother,
    Verdict,
};
use drive_sim_analysis::bootstrap::Bootstrap;
use drive_sim_calibration::params::ParamSpec;
use drive_sim_calibration::{twin, ModelParams, PlantFactory, SimFactory};
use drive_sim_log::{DriveLog, UseSteps};
use drive_sim_model::effects::{self, CommandReach, REGISTRY};
use drive_sim_sim::SensorNoise;
use search::{SearchOptions, SearchSummary};
use serde::{Deserialize, Serialize};

/// Offset of the check seeds from the choosing ones.
pub const CHECK_SEED_OFFSET: u64 = 1000;
/// Offset of the judging seeds from the choosing ones.
pub const JUDGE_SEED_OFFSET: u64 = 2000;
/// The sampler of every run (the paper's).
pub const SAMPLER: &str = "uniform-wheel";
/// Most parameters tuned at once: the design has one Halton base per parameter, and a
/// closed-loop search in more dimensions than this does not fit a budget of minutes.
pub const MAX_TUNED: usize = search::DESIGN_BASES.len();

/// Options of [`tune`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct TuneOptions {
    /// Steps of the real log the choice uses; the other half (if any) judges it.
    pub choose_on: UseSteps,
    /// DRIVE steps of each simulated run; `None`: as many as the real steps the choice uses,
    /// so that the T/U areas (hulls, which grow with the number of steps) compare like with
    /// like.
    pub steps: Option<u32>,
    /// First seed (see the module doc for the three sets).
    pub seed: u64,
    /// Seeds every point of the search is run with.
    pub choose_seeds: u32,
    /// Fresh seeds of the check, and of the judgement.
    pub check_seeds: u32,
    /// The search's budget.
    pub search: SearchOptions,
    /// Bootstrap resamples of the loss's intervals during the search and the check (the
    /// judgement uses `compare`'s default).
    pub loss_resamples: usize,
    /// Smoother of the compared maps, in the loss and in the judgement (`compare`'s).
    #[serde(default)]
    pub tf_smoother: TfSmoother,
}

impl Default for TuneOptions {
    fn default() -> Self {
        Self {
            choose_on: UseSteps::All,
            steps: None,
            seed: 0,
            choose_seeds: 3,
            check_seeds: 3,
            search: SearchOptions::default(),
            loss_resamples: 500,
            tf_smoother: TfSmoother::Kernel,
        }
    }
}

impl TuneOptions {
    /// Checks the numbers before any run (bad input names the option).
    pub fn validate(&self) -> Result<()> {
        let bad = |opt: &str, why: String| Err(Error::config("<command line>", opt, why));
        check_run_steps(self.steps)?;
        if self.choose_seeds == 0 || self.choose_seeds > 64 {
            return bad("--seeds", format!("must be in 1..=64, got {}", self.choose_seeds));
        }
        if self.check_seeds < 2 || self.check_seeds > 64 {
            return bad(
                "--check-seeds",
                format!(
                    "must be in 2..=64 (a standard error needs two), got {}",
                    self.check_seeds
                ),
            );
        }
        if self.search.max_evaluations < 2 || self.search.max_evaluations > 10_000 {
            return bad(
                "--max-evaluations",
                format!("must be in 2..=10000, got {}", self.search.max_evaluations),
            );
        }
        if self.loss_resamples < 100 {
            return bad(
                "--loss-resamples",
                format!("must be at least 100, got {}", self.loss_resamples),
            );
        }
        Ok(())
    }

    fn seeds(&self, offset: u64, n: u32) -> Vec<u64> {
        (0..n as u64).map(|i| self.seed + offset + i).collect()
    }
}

/// What to tune, from where, against which log.
#[derive(Debug, Clone, Copy)]
pub struct TuneRequest<'a> {
    /// The real log (all its steps; the options say which half chooses).
    pub real: &'a DriveLog,
    /// The model tuning starts from (e.g. a calibrated twin, or the declared robot and terrain),
    /// its effects lifted out of the files ([`twin::lift_effects`]).
    pub start: &'a ModelParams,
    /// Names of what to tune: an effect (all its parameters), an effect parameter, or a
    /// simulator base parameter (`terrain.friction.peak_lateral`, ...).
    pub tune: &'a [String],
    /// Search boxes replacing the registry's for some of them.
    pub boxes: &'a [BoxOverride],
    /// Options.
    pub opts: &'a TuneOptions,
}

/// Tunes (see the module doc). Bad input (unknown names, options, a log of another robot, too
/// few steps) is refused before the first run. `progress` hears of each phase and of each
/// point of the search.
pub fn tune(req: &TuneRequest, progress: &(dyn Fn(&TuneEvent) + Sync)) -> Result<TuneOutcome> {
    let opts = req.opts;
    opts.validate()?;
    let real = req.real;
    check_same_robot(real, req.start, "tuned")?;
    let chosen = real_steps(real, opts.choose_on, "--choose-on", "tune on")?;
    // The held-out half, with its analysed steps.
    let heldout_half = opts
        .choose_on
        .other_half()
        .map(|h| real_steps(real, h, "--choose-on", "tune on"))
        .transpose()?;
    let space = Space::new(req, &chosen.log)?;
    let steps = opts.steps.unwrap_or(chosen.analysed as u32);
    // The real steps the search and the check compare with, analysed once.
    let loss_real = PreparedReal::new(
        Input {
            log: &chosen.log,
            file: None,
        },
        &loss_opts(opts.loss_resamples, opts.tf_smoother),
    )?;
    let choose_seeds = opts.seeds(0, opts.choose_seeds);
    progress(&TuneEvent::Started {
        dataset: &real.meta.name,
        choose_on: opts.choose_on,
        real_steps: chosen.analysed,
        params: space.specs.len(),
        steps_per_run: steps,
        seeds: choose_seeds.len(),
        max_points: opts.search.max_evaluations,
    });
    let runs = LossRuns {
        real: &loss_real,
        steps,
    };
    // 1. The choice.
    let choice = choose(&space, &runs, &choose_seeds, &opts.search, progress)?;
    // 2. The check on fresh seeds.
    let check_seeds = opts.seeds(CHECK_SEED_OFFSET, opts.check_seeds);
    let check = runs.check(check_seeds, req.start, &choice.model, progress);
    // 3. The judgement: on the other half when the choice used one (held out), else on the
    // choosing steps themselves with fresh seeds (labelled: not a held-out result).
    let judging = Judging {
        smoother: opts.tf_smoother,
        seeds: opts.seeds(JUDGE_SEED_OFFSET, opts.check_seeds),
        models: [req.start, &choice.model],
        steps,
    };
    let (heldout, same_steps) = match &heldout_half {
        Some(h) => (Some(judging.on(h, Some(&chosen.log), progress)), None),
        None => (None, Some(judging.on(&chosen, None, progress))),
    };
    let params = tuned_params(&space, &choice.x_best);
    let notes = notes(heldout.is_none(), &choice.summary, &params);
    let accepted = check.accepted;
    Ok(TuneOutcome {
        dataset: real.meta.name.clone(),
        robot: real.meta.robot.clone(),
        options: *opts,
        real_steps_chosen_on: chosen.analysed,
        steps_per_run: steps,
        choose_seeds,
        params,
        evaluations: choice.evaluations,
        search: choice.summary,
        start_loss: choice.start.loss,
        start_evaluation: choice.start,
        chosen_loss: choice.loss,
        check,
        heldout,
        same_steps,
        accepted,
        notes,
        model: Some(if accepted { choice.model } else { req.start.clone() }),
    })
}

/// Each parameter: its box, the start model's value, where the search started and the choice.
fn tuned_params(space: &Space, x_best: &[f64]) -> Vec<TunedParam> {
    space
        .specs
        .iter()
        .zip(space.x0.iter().zip(x_best))
        .map(|(s, (a, b))| TunedParam {
            name: s.param.name(),
            unit: s.param.unit().to_string(),
            lower: s.lower,
            upper: s.upper,
            start: Some(s.param.get(space.start)).filter(|v| v.is_finite() && s.param.neutral() != Some(*v)),
            search_start: *a,
            chosen: *b,
            at_bound: s.at_bound(*b),
        })
        .collect()
}

/// What the outcome says in words: a judgement that is not held out, a search that did not
/// converge, parameters that ended on their box.
fn notes(not_held_out: bool, summary: &SearchSummary, params: &[TunedParam]) -> Vec<String> {
    let mut notes = Vec::new();
    if not_held_out {
        notes.push("chosen on every step: judged on the same steps with fresh seeds (`same_steps`), not held out (choose on odd or even steps for a held-out judgement)".into());
    }
    if !summary.converged {
        notes.push(format!("the search did not converge: {}", summary.stop));
    }
    for p in params.iter().filter(|p| p.at_bound) {
        notes.push(format!(
            "`{}` ended on its box [{}, {}]: a stand-in for something else, or a box too small",
            p.name, p.lower, p.upper
        ));
    }
    notes
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn options_are_checked_before_any_run() {
        let bad = TuneOptions {
            check_seeds: 1,
            ..TuneOptions::default()
        };
        assert!(bad.validate().unwrap_err().to_string().contains("--check-seeds"));
        let bad = TuneOptions {
            steps: Some(3),
            ..TuneOptions::default()
        };
        assert!(bad.validate().unwrap_err().to_string().contains("--steps"));
        TuneOptions::default().validate().unwrap();
    }
}
