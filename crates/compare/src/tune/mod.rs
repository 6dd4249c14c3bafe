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
//! twin/terrain.toml --steps N --seed S` (uniform-wheel sampler, typical sensor noise), held
//! in memory.

mod outcome;
mod params;
mod runs;
pub mod search;
pub mod write;

use outcome::check_rule;
pub use outcome::{HeldOut, JudgedRun, PointEvaluation, SeedCheck, TuneOutcome, TunedParam};
pub use params::{apply_boxes, tuned_specs, BoxOverride};
pub use runs::twin_run;
use runs::{evaluation, judged, loss_opts, run_against, seed_run, SeedRun};
pub use write::twin_of;

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
use drive_sim_model::error::{Error, Result};
use drive_sim_sim::SensorNoise;
use rayon::prelude::*;
use search::{SearchOptions, SearchSummary};
use serde::{Deserialize, Serialize};
use std::cell::RefCell;

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
/// few steps) is refused before the first run. `progress` gets one line per phase.
pub fn tune(req: &TuneRequest, progress: &(dyn Fn(&str) + Sync)) -> Result<TuneOutcome> {
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
    let (chosen_half, n_choose) = (chosen.log, chosen.analysed);
    let reach = CommandReach::of_commands(
        chosen_half.samples.iter().map(|s| s.m.cmd),
        &req.start.robot.idd(),
    );
    let mut specs = tuned_specs(req.tune, req.start, &reach)?;
    apply_boxes(&mut specs, req.boxes)?;
    let steps = opts.steps.unwrap_or(n_choose as u32);
    let lo: Vec<f64> = specs.iter().map(|s| s.lower).collect();
    let width: Vec<f64> = specs.iter().map(|s| s.upper - s.lower).collect();
    let x0: Vec<f64> = specs.iter().map(|s| s.start_in(req.start)).collect();
    let to_x = |z: &[f64]| -> Vec<f64> {
        z.iter()
            .zip(lo.iter().zip(&width))
            .map(|(z, (l, w))| l + z * w)
            .collect()
    };
    let z0: Vec<f64> = x0
        .iter()
        .zip(lo.iter().zip(&width))
        .map(|(x, (l, w))| (x - l) / w)
        .collect();
    let model_at = |x: &[f64]| req.start.with_values(&specs, x);
    // The start model as given (an effect it does not have stays off: the search's first point
    // is then mid-box, but the check compares the choice with this model).
    let start_model = req.start.clone();

    // The real steps the search and the check compare with, analysed once.
    let loss_real = PreparedReal::new(
        Input {
            log: &chosen_half,
            file: None,
        },
        &loss_opts(opts.loss_resamples, opts.tf_smoother),
    )?;
    let choose_seeds = opts.seeds(0, opts.choose_seeds);
    progress(&format!(
        "tune: {} parameter(s) on {} {} steps of `{}`, {} DRIVE steps x {} seed(s) per point, at most {} points",
        specs.len(),
        n_choose,
        opts.choose_on.as_str(),
        real.meta.name,
        steps,
        choose_seeds.len(),
        opts.search.max_evaluations
    ));
    // Every point evaluated, in order (the search calls this closure from one thread at a time;
    // each call runs its points' seeds in parallel).
    let evaluations: RefCell<Vec<PointEvaluation>> = RefCell::new(Vec::new());
    let cost_many = |zs: &[Vec<f64>]| -> Vec<Option<f64>> {
        let jobs: Vec<(usize, u64)> = (0..zs.len())
            .flat_map(|i| choose_seeds.iter().map(move |s| (i, *s)))
            .collect();
        // In the order of `jobs`: each point's seeds side by side.
        let runs: Vec<SeedRun> = jobs
            .par_iter()
            .map(|&(i, seed)| match model_at(&to_x(&zs[i])) {
                Ok(m) => seed_run(&loss_real, &m, steps, seed),
                Err(e) => SeedRun {
                    outcome: Err(e.to_string()),
                },
            })
            .collect();
        let mut evals = evaluations.borrow_mut();
        let mut out = Vec::new();
        for (z, mine) in zs.iter().zip(runs.chunks(choose_seeds.len())) {
            let e = evaluation(to_x(z), mine);
            let best = evals
                .iter()
                .chain(std::iter::once(&e))
                .filter_map(|p| p.loss)
                .fold(f64::INFINITY, f64::min);
            progress(&format!(
                "tune: point {} {} -> loss {} (best {best:.2})",
                evals.len() + 1,
                format_values(&specs, &e.values),
                e.loss.map_or_else(
                    || format!("failed ({})", e.error.clone().unwrap_or_default()),
                    |l| format!("{l:.2}")
                ),
            ));
            out.push(e.loss);
            evals.push(e);
        }
        out
    };
    // The start model on the search's seeds: the baseline the search's losses compare with.
    let start_runs: Vec<SeedRun> = choose_seeds
        .par_iter()
        .map(|&s| seed_run(&loss_real, &start_model, steps, s))
        .collect();
    let start_eval = evaluation(req.start.values_of(&specs), &start_runs);
    let start_loss = start_eval.loss;
    progress(&format!(
        "tune: the start model: loss {}",
        start_loss.map_or_else(
            || format!("failed ({})", start_eval.error.clone().unwrap_or_default()),
            |l| format!("{l:.2}")
        )
    ));
    let (z_best, chosen_loss, summary) = search::minimise(&z0, &opts.search, &cost_many);
    let evaluations = evaluations.into_inner();
    let x_best = to_x(&z_best);
    let chosen_model = model_at(&x_best)?;
    let same_point = chosen_model == start_model;
    progress(&format!(
        "tune: search done ({} points, {}): best {} loss {chosen_loss:.2} (start {})",
        summary.evaluations,
        summary.stop,
        format_values(&specs, &x_best),
        start_loss.map_or_else(|| "failed".into(), |l| format!("{l:.2}"))
    ));

    // 2. The check on fresh seeds.
    let check_seeds = opts.seeds(CHECK_SEED_OFFSET, opts.check_seeds);
    let pairs: Vec<(SeedRun, SeedRun)> = check_seeds
        .par_iter()
        .map(|&s| {
            (
                seed_run(&loss_real, &start_model, steps, s),
                seed_run(&loss_real, &chosen_model, steps, s),
            )
        })
        .collect();
    let total = |r: &SeedRun| r.outcome.as_ref().ok().map(|o| o.total);
    let check = check_rule(
        check_seeds,
        pairs.iter().map(|p| total(&p.0)).collect(),
        pairs.iter().map(|p| total(&p.1)).collect(),
        same_point,
    );
    progress(&format!(
        "tune: check on {} fresh seeds: loss reduction {:.2} ± {:.2} (SE): {}",
        check.seeds.len(),
        check.mean_reduction,
        check.se,
        if check.accepted {
            "accepted"
        } else {
            "not accepted, the twin stays the start"
        }
    ));

    // 3. The judgement: on the other half when the choice used one (held out), else on the
    // choosing steps themselves with fresh seeds (labelled: not a held-out result).
    let judge_seeds = opts.seeds(JUDGE_SEED_OFFSET, opts.check_seeds);
    let judge_on =
        |half: UseSteps, log: &DriveLog, real_steps: usize, halves: Option<&DriveLog>| -> HeldOut {
            let judging = CompareOptions {
                tf_smoother: opts.tf_smoother,
                ..CompareOptions::default()
            };
            let prepared = PreparedReal::new(Input { log, file: None }, &judging).map_err(|e| e.to_string());
            let reps: Vec<(u64, std::result::Result<ComparisonReport, String>)> = judge_seeds
                .par_iter()
                .map(|&s| {
                    let r = prepared.as_ref().map_err(Clone::clone).and_then(|p| {
                        run_against(p, &[&start_model, &chosen_model], steps, s).map_err(|e| e.to_string())
                    });
                    (s, r)
                })
                .collect();
            let real_halves = halves.map(|other| {
                let c = prepared.as_ref().map_err(Clone::clone).and_then(|p| {
                    compare_prepared(
                        p,
                        &[Input {
                            log: other,
                            file: None,
                        }],
                    )
                    .map_err(|e| e.to_string())
                });
                judged(c.as_ref(), 0, 0)
            });
            let h = HeldOut {
                real_halves,
                steps: half,
                real_steps,
                start: reps.iter().map(|(s, r)| judged(r.as_ref(), 0, *s)).collect(),
                chosen: reps.iter().map(|(s, r)| judged(r.as_ref(), 1, *s)).collect(),
                reports: reps.into_iter().filter_map(|(_, r)| r.ok()).collect(),
            };
            let mean = |runs: &[JudgedRun]| {
                let v: Vec<f64> = runs
                    .iter()
                    .filter_map(|r| r.loss.as_ref().map(|l| l.total))
                    .collect();
                v.iter().sum::<f64>() / v.len().max(1) as f64
            };
            progress(&format!(
                "tune: judged on the {} {} steps{} ({} seeds): mean loss start {:.2}, chosen {:.2}",
                h.real_steps,
                half.as_str(),
                if halves.is_some() {
                    ""
                } else {
                    " it was chosen on (not held out)"
                },
                h.start.len(),
                mean(&h.start),
                mean(&h.chosen)
            ));
            h
        };
    let (heldout, same_steps) = match &heldout_half {
        Some(h) => (
            Some(judge_on(h.steps, &h.log, h.analysed, Some(&chosen_half))),
            None,
        ),
        None => (None, Some(judge_on(opts.choose_on, &chosen_half, n_choose, None))),
    };
    let mut notes = Vec::new();
    if heldout.is_none() {
        notes.push("chosen on every step: judged on the same steps with fresh seeds (`same_steps`), not held out (choose on odd or even steps for a held-out judgement)".into());
    }
    if !summary.converged {
        notes.push(format!("the search did not converge: {}", summary.stop));
    }
    let params: Vec<TunedParam> = specs
        .iter()
        .zip(x0.iter().zip(&x_best))
        .map(|(s, (a, b))| TunedParam {
            name: s.param.name(),
            unit: s.param.unit().to_string(),
            lower: s.lower,
            upper: s.upper,
            start: Some(s.param.get(req.start)).filter(|v| v.is_finite() && s.param.neutral() != Some(*v)),
            search_start: *a,
            chosen: *b,
            at_bound: s.at_bound(*b),
        })
        .collect();
    for p in params.iter().filter(|p| p.at_bound) {
        notes.push(format!(
            "`{}` ended on its box [{}, {}]: a stand-in for something else, or a box too small",
            p.name, p.lower, p.upper
        ));
    }
    let accepted = check.accepted;
    Ok(TuneOutcome {
        dataset: real.meta.name.clone(),
        robot: real.meta.robot.clone(),
        options: *opts,
        real_steps_chosen_on: n_choose,
        steps_per_run: steps,
        choose_seeds,
        params,
        evaluations,
        search: summary,
        start_loss,
        start_evaluation: start_eval,
        chosen_loss,
        check,
        heldout,
        same_steps,
        accepted,
        notes,
        model: Some(if accepted { chosen_model } else { start_model }),
    })
}

fn format_values(specs: &[ParamSpec], x: &[f64]) -> String {
    specs
        .iter()
        .zip(x)
        .map(|(s, v)| format!("{}={v:.4}", s.param.key()))
        .collect::<Vec<_>>()
        .join(" ")
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
