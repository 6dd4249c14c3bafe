//! Judging a twin: can `compare` tell the real run from a run of the twin?
//!
//! `compare` gives a verdict per simulated run, and a twin runs its own DRIVE with a seed: one
//! run's verdict is a draw. Even an exact model is called "differs" in some of its runs (README,
//! "The yardstick over 64 halvings": 8 of 30 pairs of the same model with the paper's maps), so
//! "reproduces in k of 3 seeds" says little either way. This stage asks the question the
//! verdict stands for, with a test whose error rate is known:
//!
//! 1. The twin runs `sims` DRIVE runs (seeds `seed + i`), each compared with the real steps
//!    (`real_steps`: all, or the half the twin was not calibrated on). For each criterion of
//!    the verdict (the verdict itself, each median's Holm test, each T/U area's tolerance, each
//!    map's yardstick) the statistic is how many of the runs fail it; the loss's statistic is
//!    their mean loss.
//! 2. The twin also runs `references` DRIVE runs of its own (seeds `seed +
//!    REFERENCE_SEED_OFFSET + j`), and each takes the real run's place: the same `sims` runs are
//!    compared with it, giving the same statistics. A reference is drawn as the real steps
//!    were: when they are one half of a run (its odd or even steps), each reference is the same
//!    half of a twin run as long as the real run ([`ReferenceRuns`]). Why not a run as long as
//!    the half: a DRIVE run's consecutive steps are not independent (the site sends the robot
//!    back, the operator's manoeuvres and the interruptions follow where the last step left
//!    it), so a run's every other step mixes its commands differently from a run of half the
//!    length. Judged on the odd and even steps of five of its own 201-step runs, the twin of
//!    `husky_2023` was told apart from itself in three of the ten halves at 0.05 when its
//!    references were 101-step runs, in none since.
//! 3. Every run of the twin, the references and the runs of 1. alike, draws its commands as
//!    the real steps were drawn, quadrant by quadrant: each step uniformly in U inside the
//!    quadrant (forward or backward, turning left or right) of the real step's command
//!    ([`crate::tune::twin_run_matched`]). Which quadrant a step drew is the sampler's luck, not
//!    the robot's, and a run's medians are its quadrants' mix: `warthog_asphalt` drew 36 left
//!    turns in 98 analysed steps (a fair coin's two-sided p 0.011,
//!    [`drive_sim_analysis::command_mix`]), and against references drawn uniformly its median
//!    yaw slip was the right turns' where theirs fell either way. The test conditions on the
//!    mix, which does not depend on the robot; under the hypothesis it stays exact.
//! 4. If the real robot were the twin, the real run would be one more draw like the references,
//!    and the `references + 1` statistics would be exchangeable (the same simulated runs are
//!    compared with each). The Monte Carlo p-value of a statistic is then `(1 + #{references
//!    at least as extreme as the real run}) / (references + 1)` (Barnard 1963; Besag & Diggle
//!    1977): exact at any number of references, with resolution `1 / (references + 1)`.
//!
//! The twin is **distinguishable** from the real run when the loss's p-value is at most `alpha`
//! (the Monte Carlo test's rule: with 19 references and `alpha` 0.05, when the real run is the
//! most extreme of the 20), else **indistinguishable** as far as `compare` can tell. The loss
//! is the verdict's criteria in continuous form (each term 1 at its threshold), so it decides:
//! the count of runs called "differs" has the same hypothesis but little power where the
//! twin's runs already fail one another often (a half run of 49 steps: 3–5 of 10 on average),
//! and it ties. Its p-value, and each criterion's, are reported beside it: they say where a
//! distinguishable twin falls short.
//!
//! Runs have as many DRIVE steps as the judged real steps unless told otherwise (a T/U area
//! is a hull, which grows with the number of steps; a half's references are that half of runs
//! as long as the real log, see 2. above), and every run, the references included,
//! is the protocol of `drive-sim run --robot twin/robot.toml --terrain twin/terrain.toml
//! --steps N --seed S`, held in memory.

mod event;
pub mod interval;
mod outcome;
mod score;
pub mod write;
mod yardstick;

pub use event::JudgeEvent;
pub use outcome::{CandidateScore, CriterionTest, JudgeOutcome, LossTest, RunScore, TermMean, TermTest};
pub use score::{criteria_of, monte_carlo_p};
pub use yardstick::{check_same_ground, p_farther, yardsticks, Yardstick, YardstickRequest};

use crate::error::{Error, Result};
use crate::real_steps::{check_run_steps, check_same_robot, real_steps, RealSteps};
use crate::tune::twin_run_matched;
use crate::{CompareOptions, Input, PreparedSim, TfSmoother};
use drive_sim_analysis::bootstrap::Bootstrap;
use drive_sim_calibration::ModelParams;
use drive_sim_log::{DriveLog, UseSteps};
use drive_sim_model::kinematics::WheelSpeeds;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Arc;

/// Offset of the reference runs' seeds from the simulated runs'.
pub const REFERENCE_SEED_OFFSET: u64 = 5000;
/// The verdict's criterion name: the run is not called "reproduces".
pub const DIFFERS: &str = "differs";
/// The step scatter's criterion name ([`crate::scatter`]), and its term's in the loss:
/// outside the verdict, counted like the others so that a twin without the real run's
/// step-to-step scatter shows it.
pub const STEP_SCATTER: &str = "step_scatter";
/// The turn memory's criterion name ([`crate::turn_memory`]): outside the verdict,
/// counted like the step scatter.
pub const TURN_MEMORY: &str = "turn_memory";

/// Options of [`judge`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct JudgeOptions {
    /// The real steps judged against: all, or the half the twin was not calibrated on.
    pub real_steps: UseSteps,
    /// DRIVE steps of each run; `None`: as many as the judged real steps.
    pub steps: Option<u32>,
    /// First seed of the simulated runs (the references start at `seed +
    /// REFERENCE_SEED_OFFSET`).
    pub seed: u64,
    /// Simulated runs compared with the real run and with each reference.
    pub sims: u32,
    /// Reference runs of the twin, each in the real run's place.
    pub references: u32,
    /// Smoother of the compared maps (`compare --tf-smoother`).
    pub tf_smoother: TfSmoother,
    /// Bootstrap resamples of each comparison's intervals (`compare --resamples`).
    pub resamples: usize,
    /// Level of the tests (compare's, and the indistinguishability's).
    pub alpha: f64,
}

impl Default for JudgeOptions {
    fn default() -> Self {
        Self {
            real_steps: UseSteps::All,
            steps: None,
            seed: 0,
            sims: 10,
            references: 19,
            tf_smoother: TfSmoother::Kernel,
            resamples: Bootstrap::default().resamples,
            alpha: CompareOptions::default().alpha,
        }
    }
}

impl JudgeOptions {
    /// Checks the numbers before any run (bad input names the option).
    pub fn validate(&self) -> Result<()> {
        let bad = |opt: &str, why: String| Err(Error::config("<command line>", opt, why));
        check_run_steps(self.steps)?;
        if !(2..=64).contains(&self.sims) {
            return bad("--sims", format!("must be in 2..=64, got {}", self.sims));
        }
        if !(4..=999).contains(&self.references) {
            return bad(
                "--references",
                format!(
                    "must be in 4..=999 (the smallest p-value is 1 / (references + 1): 19 for 0.05), got {}",
                    self.references
                ),
            );
        }
        if self.resamples < 100 {
            return bad(
                "--resamples",
                format!("must be at least 100, got {}", self.resamples),
            );
        }
        if !(self.alpha > 0.0 && self.alpha < 1.0) {
            return bad("--alpha", format!("must be in (0, 1), got {}", self.alpha));
        }
        // A test whose smallest p-value is above its level can never tell the twin apart: its
        // "indistinguishable" would be no judgement at all.
        let smallest_p = 1.0 / (self.references as f64 + 1.0);
        if smallest_p > self.alpha {
            return bad(
                "--references",
                format!(
                    "{} references cannot reach --alpha {}: the smallest p-value is 1 / (references + 1) = {:.3}; give at least {}",
                    self.references,
                    self.alpha,
                    smallest_p,
                    (1.0 / self.alpha - 1.0 - 1e-9).ceil()
                ),
            );
        }
        Ok(())
    }

    pub(crate) fn compare_options(&self) -> CompareOptions {
        CompareOptions {
            bootstrap: Bootstrap {
                resamples: self.resamples,
                ..Bootstrap::default()
            },
            alpha: self.alpha,
            // The permutation test of the maps is a diagnostic outside the verdict; it would
            // cost every comparison a few hundred smoothings.
            tf_permutations: 0,
            tf_smoother: self.tf_smoother,
            ..CompareOptions::default()
        }
    }
}

/// What to judge against what.
#[derive(Debug, Clone, Copy)]
pub struct JudgeRequest<'a> {
    /// The real log (all its steps; the options say which are judged).
    pub real: &'a DriveLog,
    /// The twin (robot and terrain with their effects, as [`drive_sim_calibration::twin::lift_effects`]
    /// reads them from the twin files).
    pub model: &'a ModelParams,
    /// Options.
    pub opts: &'a JudgeOptions,
}

/// Judges the twin (see the module doc). Bad input (options, a log of another robot, too few
/// real steps) is refused before the first run. `progress` hears of each phase.
pub fn judge(req: &JudgeRequest, progress: &(dyn Fn(&JudgeEvent) + Sync)) -> Result<JudgeOutcome> {
    let opts = req.opts;
    opts.validate()?;
    let real = req.real;
    check_same_robot(real, req.model, "judged")?;
    let RealSteps {
        log: judged,
        analysed: n_real,
        ..
    } = real_steps(real, opts.real_steps, "--real-steps", "judge against")?;
    let steps = opts.steps.unwrap_or(n_real as u32);
    let reference_runs = ReferenceRuns::of(real, opts, steps);
    let mut notes = Vec::new();
    progress(&JudgeEvent::Started {
        dataset: &real.meta.name,
        real_steps: opts.real_steps,
        real_steps_analysed: n_real,
        sims: opts.sims,
        references: opts.references,
        steps_per_run: steps,
    });
    let sims = twin_runs(req.model, opts, steps, &judged.held_commands(), &mut notes)?;
    // Each run is analysed once, for the real run and every reference.
    let seeds: Vec<u64> = sims.iter().map(|(s, _)| *s).collect();
    let prepared = sims
        .iter()
        .map(|(_, log)| PreparedSim::new(Input { log, file: None }))
        .collect::<Result<Vec<_>>>()?;
    let scoring = Scoring {
        model: req.model,
        seeds: &seeds,
        sims: &prepared,
        reference_runs,
        copts: opts.compare_options(),
    };
    let (real_score, names) = scoring.score("real", None, &judged)?;
    progress(&JudgeEvent::AgainstReal { score: &real_score });
    let references = scoring.references(opts, &mut notes, progress)?;
    let criteria = score::criterion_tests(&names, &real_score, &references, sims.len());
    let ref_losses: Vec<f64> = references.iter().map(|c| c.mean_loss).collect();
    let loss = LossTest {
        real: real_score.mean_loss,
        p: monte_carlo_p(real_score.mean_loss, &ref_losses),
        references: ref_losses,
        terms: score::term_tests(&real_score, &references),
    };
    let outcome = JudgeOutcome {
        dataset: real.meta.name.clone(),
        robot: real.meta.robot.clone(),
        options: *opts,
        real_steps_analysed: n_real,
        steps_per_run: steps,
        reference_run_steps: scoring.reference_runs.steps,
        reference_steps: scoring.reference_runs.half,
        sim_seeds: seeds,
        reference_seeds: references.iter().filter_map(|c| c.seed).collect(),
        // The Monte Carlo test's rule: reject when p <= alpha (with 19 references and alpha
        // 0.05, when the real run is the most extreme of the 20; exact size alpha under the
        // hypothesis).
        indistinguishable: loss.p > opts.alpha,
        short_on: score::criteria_at_most(&criteria, opts.alpha, |c| c.p_holm),
        flagged: score::criteria_at_most(&criteria, opts.alpha, |c| c.p),
        criteria,
        loss,
        real: real_score,
        references,
        notes,
        intervals: Vec::new(),
        yardsticks: Vec::new(),
    };
    progress(&JudgeEvent::Decided { outcome: &outcome });
    Ok(outcome)
}

/// The twin's runs of seeds `seed..` (in parallel, in seed order), drawn in the quadrants of
/// the commands `like` (the judged steps'); a run that fails is left out with a note. Fewer
/// than two completed: nothing to judge.
fn twin_runs(
    model: &ModelParams,
    opts: &JudgeOptions,
    steps: u32,
    like: &[WheelSpeeds],
    notes: &mut Vec<String>,
) -> Result<Vec<(u64, DriveLog)>> {
    let sim_seeds: Vec<u64> = (0..opts.sims as u64).map(|i| opts.seed + i).collect();
    let runs: Vec<(u64, Result<DriveLog>)> = sim_seeds
        .par_iter()
        .map(|&s| (s, twin_run_matched(model, like, steps, s)))
        .collect();
    let mut sims = Vec::new();
    for (s, r) in runs {
        match r {
            Ok(log) => sims.push((s, log)),
            Err(e) => notes.push(format!(
                "simulated run of seed {s} failed ({e}): left out of every comparison"
            )),
        }
    }
    if sims.len() < 2 {
        return Err(Error::TooFewTwinRuns {
            completed: sims.len(),
            asked: opts.sims,
            errors: notes.clone(),
        });
    }
    Ok(sims)
}

/// How a reference run is drawn so that it stands in the real steps' place: `half` of a twin
/// run of `steps` DRIVE steps, its commands drawn in the quadrants of a real run's.
#[derive(Debug, Clone, PartialEq)]
pub struct ReferenceRuns {
    /// DRIVE steps of the twin's run.
    pub steps: u32,
    /// Its steps kept: those of the judged real steps.
    pub half: UseSteps,
    /// The real run's commands (all its steps): step `i` of the twin's run draws in the
    /// quadrant of command `i` ([`Matched`](drive_sim_protocol::samplers::matched::Matched)).
    pub like: Arc<[WheelSpeeds]>,
}

impl ReferenceRuns {
    /// The references of real steps `opts.real_steps` of `real`, whose simulated runs have
    /// `steps` DRIVE steps: every step of such a run when every real step is judged; else the
    /// same half of a run as long as the real log (twice `steps` when the options set the runs'
    /// length). Each draws in the quadrants of `real`'s commands.
    pub fn of(real: &DriveLog, opts: &JudgeOptions, steps: u32) -> Self {
        match (opts.real_steps, opts.steps) {
            (UseSteps::All, _) => Self::whole(real, steps),
            (half, Some(n)) => Self {
                steps: 2 * n,
                half,
                like: real.held_commands().into(),
            },
            (half, None) => Self::half_of(real, half),
        }
    }

    /// Every step of a run of `steps` DRIVE steps drawn as `real` was.
    pub fn whole(real: &DriveLog, steps: u32) -> Self {
        Self {
            steps,
            half: UseSteps::All,
            like: real.held_commands().into(),
        }
    }

    /// The steps `half` of a run as long as `real`, drawn as `real` was.
    pub fn half_of(real: &DriveLog, half: UseSteps) -> Self {
        Self {
            steps: real.steps().len() as u32,
            half,
            like: real.held_commands().into(),
        }
    }

    /// The reference run of `seed`.
    pub fn run(&self, model: &ModelParams, seed: u64) -> Result<DriveLog> {
        twin_run_matched(model, &self.like, self.steps, seed).map(|log| self.half.select(&log))
    }
}

/// The twin's runs, analysed once, and how every candidate is compared with them.
struct Scoring<'a> {
    model: &'a ModelParams,
    seeds: &'a [u64],
    sims: &'a [PreparedSim<'a>],
    /// How a reference run is drawn.
    reference_runs: ReferenceRuns,
    copts: CompareOptions,
}

impl Scoring<'_> {
    /// The runs against one candidate's steps, with the criteria's names.
    fn score(
        &self,
        label: &str,
        seed: Option<u64>,
        candidate: &DriveLog,
    ) -> Result<(CandidateScore, Vec<String>)> {
        score::score(label, seed, candidate, (self.seeds, self.sims), &self.copts)
    }

    /// The reference runs (seeds `seed + REFERENCE_SEED_OFFSET..`, in parallel), each scored in
    /// the real run's place; one that fails is left out with a note. Fewer than four: too few
    /// for a p-value. Adds the note on the p-values' resolution.
    fn references(
        &self,
        opts: &JudgeOptions,
        notes: &mut Vec<String>,
        progress: &(dyn Fn(&JudgeEvent) + Sync),
    ) -> Result<Vec<CandidateScore>> {
        let reference_seeds: Vec<u64> = (0..opts.references as u64)
            .map(|j| opts.seed + REFERENCE_SEED_OFFSET + j)
            .collect();
        let done = AtomicUsize::new(0);
        let refs: Vec<(u64, Result<CandidateScore>)> = reference_seeds
            .par_iter()
            .map(|&s| {
                let r = self
                    .reference_runs
                    .run(self.model, s)
                    .and_then(|log| self.score("reference", Some(s), &log))
                    .map(|(c, _)| c);
                let k = done.fetch_add(1, Ordering::Relaxed) + 1;
                if let Ok(score) = &r {
                    progress(&JudgeEvent::Reference {
                        done: k,
                        of: reference_seeds.len(),
                        seed: s,
                        score,
                    });
                }
                (s, r)
            })
            .collect();
        let mut references = Vec::new();
        for (s, r) in refs {
            match r {
                Ok(c) => references.push(c),
                Err(e) => notes.push(format!("reference run of seed {s} failed ({e}): left out")),
            }
        }
        if references.len() < 4 {
            return Err(Error::TooFewReferences {
                completed: references.len(),
                asked: opts.references,
                errors: notes.clone(),
            });
        }
        notes.push(format!(
            "p-values are Monte Carlo ranks among {} reference runs: none is below {:.3}",
            references.len(),
            1.0 / (references.len() + 1) as f64
        ));
        Ok(references)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn options_are_checked_before_any_run() {
        for (bad, flag) in [
            (
                JudgeOptions {
                    sims: 1,
                    ..JudgeOptions::default()
                },
                "--sims",
            ),
            (
                JudgeOptions {
                    references: 3,
                    ..JudgeOptions::default()
                },
                "--references",
            ),
            (
                JudgeOptions {
                    steps: Some(5),
                    ..JudgeOptions::default()
                },
                "--steps",
            ),
            // 9 references reach p = 0.1, not 0.05.
            (
                JudgeOptions {
                    references: 9,
                    ..JudgeOptions::default()
                },
                "--references",
            ),
            (
                JudgeOptions {
                    alpha: 1.0,
                    ..JudgeOptions::default()
                },
                "--alpha",
            ),
        ] {
            assert!(bad.validate().unwrap_err().to_string().contains(flag), "{flag}");
        }
        JudgeOptions::default().validate().unwrap();
    }
}
