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
//!    compared with it, giving the same statistics.
//! 3. If the real robot were the twin, the real run would be one more draw like the references,
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
//! is a hull, which grows with the number of steps), and every run, the references included,
//! is the protocol of `drive-sim run --robot twin/robot.toml --terrain twin/terrain.toml
//! --steps N --seed S`, held in memory.

pub mod interval;
pub mod write;

use crate::real_steps::{check_run_steps, check_same_robot, real_steps, RealSteps};
use crate::tune::twin_run;
use crate::{
    compare_prepared_sims, CompareOptions, Input, PreparedReal, PreparedSim, SimComparison, TfSmoother,
};
use drive_sim_analysis::bootstrap::{holm, Bootstrap};
use drive_sim_calibration::ModelParams;
use drive_sim_log::{DriveLog, UseSteps};
use drive_sim_model::error::{Error, Result};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// Offset of the reference runs' seeds from the simulated runs'.
pub const REFERENCE_SEED_OFFSET: u64 = 5000;
/// The verdict's criterion name: the run is not called "reproduces".
pub const DIFFERS: &str = "differs";
/// The step scatter's criterion name ([`crate::scatter`]): outside the verdict, counted
/// like the others so that a twin without the real run's step-to-step scatter shows it.
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
        Ok(())
    }

    fn compare_options(&self) -> CompareOptions {
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

/// One simulated run against one candidate (the real run or a reference): the criteria it
/// fails and its loss.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RunScore {
    /// Seed of the simulated run.
    pub sim_seed: u64,
    /// Criteria failed ([`DIFFERS`] when the verdict is not "reproduces").
    pub failed: Vec<String>,
    /// The loss of [`crate::loss`] (each term 1 at its verdict's threshold).
    pub loss: Option<f64>,
}

/// The simulated runs against one candidate.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CandidateScore {
    /// `real` or `reference`.
    pub label: String,
    /// Seed of a reference run (`None` for the real run).
    pub seed: Option<u64>,
    /// Its analysed steps.
    pub steps: usize,
    /// Each simulated run against it.
    pub runs: Vec<RunScore>,
    /// Runs failing each criterion, in the order of [`JudgeOutcome::criteria`].
    pub fails: Vec<usize>,
    /// Mean loss of the runs.
    pub mean_loss: f64,
}

/// One criterion's test.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CriterionTest {
    /// [`DIFFERS`], a median (`median_rho`, `median_slip_vx`, ...), an area
    /// (`t_area_pct_body`), or a map (`vx map`, ...).
    pub criterion: String,
    /// Simulated runs failing it against the real run.
    pub real_fails: usize,
    /// The same against each reference run.
    pub reference_fails: Vec<usize>,
    /// Mean of `reference_fails` / runs: how often a run of the twin fails it against the twin.
    pub reference_rate: f64,
    /// Monte Carlo p-value: (1 + references failing at least as many runs) / (references + 1).
    pub p: f64,
    /// Holm-adjusted over the criteria other than [`DIFFERS`] (for [`DIFFERS`]: `p`).
    pub p_holm: f64,
}

/// The loss's test.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LossTest {
    /// Mean loss of the simulated runs against the real run.
    pub real: f64,
    /// The same against each reference.
    pub references: Vec<f64>,
    /// Monte Carlo p-value: (1 + references with a mean loss at least the real's) /
    /// (references + 1).
    pub p: f64,
}

/// Everything [`judge`] found (`judge.json`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct JudgeOutcome {
    /// The real log.
    pub dataset: String,
    /// Its robot.
    pub robot: String,
    /// Options.
    pub options: JudgeOptions,
    /// Analysed real steps judged against.
    pub real_steps_analysed: usize,
    /// DRIVE steps of each run.
    pub steps_per_run: u32,
    /// Seeds of the simulated runs that completed.
    pub sim_seeds: Vec<u64>,
    /// Seeds of the reference runs that completed.
    pub reference_seeds: Vec<u64>,
    /// The tests, [`DIFFERS`] first.
    pub criteria: Vec<CriterionTest>,
    /// The loss's test.
    pub loss: LossTest,
    /// The loss's p-value is above `alpha`: `compare` cannot tell the real run from the twin's
    /// own runs.
    pub indistinguishable: bool,
    /// Criteria whose Holm-adjusted p-value is at most `alpha`: where the twin falls short.
    /// (Holm over the 14 criteria, the verdict's 13 and the step scatter, needs more references
    /// than the default 19 to reach 0.05.)
    pub short_on: Vec<String>,
    /// Criteria whose own p-value is at most `alpha`, uncorrected: a diagnostic of where the
    /// real run is more extreme than (nearly) every reference, not a test (14 criteria at 5 %
    /// flag about 0.7 of them for a perfect twin).
    pub flagged: Vec<String>,
    /// The simulated runs against the real run.
    pub real: CandidateScore,
    /// The simulated runs against each reference run.
    pub references: Vec<CandidateScore>,
    /// What happened, in words (runs that failed, the p-values' resolution).
    pub notes: Vec<String>,
    /// Sets of the twin's parameters by inverting this test (`judge --interval`,
    /// [`interval`]); empty unless asked.
    #[serde(default)]
    pub intervals: Vec<interval::ParamInterval>,
}

/// The criteria a comparison fails, in a fixed order: the verdict, the medians, the areas,
/// the maps, then the step scatter ([`STEP_SCATTER`]) and the turn memory ([`TURN_MEMORY`]),
/// diagnostics outside the verdict and the loss (their intervals miss each other). Returns
/// (names, failed flags).
pub fn criteria_of(c: &SimComparison) -> Vec<(String, bool)> {
    let mut out = vec![(DIFFERS.to_string(), !c.verdict.reproduces)];
    for m in c.metrics.iter().filter(|m| m.tolerance.is_none()) {
        out.push((m.metric.clone(), m.significant));
    }
    for m in c.metrics.iter().filter(|m| m.tolerance.is_some()) {
        out.push((m.metric.clone(), m.within_tolerance == Some(false)));
    }
    for t in &c.transfer {
        out.push((format!("{} map", t.channel), t.points > 0 && !t.within));
    }
    out.push((
        STEP_SCATTER.to_string(),
        c.step_scatter.is_some_and(|d| d.differs),
    ));
    out.push((TURN_MEMORY.to_string(), c.turn_memory.is_some_and(|d| d.differs)));
    out
}

/// Monte Carlo p-value of an observed statistic among references drawn under the hypothesis
/// (larger is more extreme): `(1 + #{r ≥ observed}) / (n + 1)` over the finite references.
/// NaN without a finite reference or a finite observation.
pub fn monte_carlo_p(observed: f64, references: &[f64]) -> f64 {
    let finite: Vec<f64> = references.iter().copied().filter(|r| r.is_finite()).collect();
    if finite.is_empty() || !observed.is_finite() {
        return f64::NAN;
    }
    let at_least = finite.iter().filter(|&&r| r >= observed).count();
    (1 + at_least) as f64 / (finite.len() + 1) as f64
}

/// Scores the simulated runs (their seeds, and the runs analysed once) against one candidate's
/// steps.
fn score(
    label: &str,
    seed: Option<u64>,
    candidate: &DriveLog,
    sims: (&[u64], &[PreparedSim]),
    copts: &CompareOptions,
) -> Result<(CandidateScore, Vec<String>)> {
    let prepared = PreparedReal::new(
        Input {
            log: candidate,
            file: None,
        },
        copts,
    )?;
    let (sim_seeds, sims) = sims;
    let report = compare_prepared_sims(&prepared, sims)?;
    let steps = report.real.steps;
    let mut names = Vec::new();
    let mut fails: Vec<usize> = Vec::new();
    let mut runs = Vec::new();
    for (sim_seed, c) in sim_seeds.iter().zip(&report.sims) {
        let crit = criteria_of(c);
        if names.is_empty() {
            names = crit.iter().map(|(n, _)| n.clone()).collect();
            fails = vec![0; names.len()];
        }
        for (k, (_, failed)) in crit.iter().enumerate() {
            fails[k] += usize::from(*failed);
        }
        runs.push(RunScore {
            sim_seed: *sim_seed,
            failed: crit.into_iter().filter(|(_, f)| *f).map(|(n, _)| n).collect(),
            loss: c.loss.as_ref().map(|l| l.total),
        });
    }
    let mean_loss = drive_sim_analysis::stats::mean(
        &runs
            .iter()
            .map(|r| r.loss.unwrap_or(f64::NAN))
            .collect::<Vec<_>>(),
    );
    Ok((
        CandidateScore {
            label: label.into(),
            seed,
            steps,
            runs,
            fails,
            mean_loss,
        },
        names,
    ))
}

/// Judges the twin (see the module doc). Bad input (options, a log of another robot, too few
/// real steps) is refused before the first run. `progress` gets one line per phase.
pub fn judge(req: &JudgeRequest, progress: &(dyn Fn(&str) + Sync)) -> Result<JudgeOutcome> {
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
    let copts = opts.compare_options();
    let mut notes = Vec::new();
    progress(&format!(
        "judge: {} runs of the twin against the {n_real} {} steps of `{}` and against {} runs of its own, {steps} DRIVE steps each",
        opts.sims,
        opts.real_steps.as_str(),
        real.meta.name,
        opts.references
    ));
    // The simulated runs, held for every comparison.
    let sim_seeds: Vec<u64> = (0..opts.sims as u64).map(|i| opts.seed + i).collect();
    let runs: Vec<(u64, Result<DriveLog>)> = sim_seeds
        .par_iter()
        .map(|&s| (s, twin_run(req.model, steps, s)))
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
        return Err(Error::Analysis(format!(
            "judge: {} of {} runs of the twin completed: nothing to judge (see the runs' errors: {})",
            sims.len(),
            opts.sims,
            notes.join("; ")
        )));
    }
    // Each run is analysed once, for the real run and every reference.
    let seeds: Vec<u64> = sims.iter().map(|(s, _)| *s).collect();
    let prepared = sims
        .iter()
        .map(|(_, log)| PreparedSim::new(Input { log, file: None }))
        .collect::<Result<Vec<_>>>()?;
    let (real_score, names) = score("real", None, &judged, (&seeds, &prepared), &copts)?;
    progress(&format!(
        "judge: against the real run: {} of {} runs differ, mean loss {:.2}",
        real_score.fails[0],
        sims.len(),
        real_score.mean_loss
    ));
    let reference_seeds: Vec<u64> = (0..opts.references as u64)
        .map(|j| opts.seed + REFERENCE_SEED_OFFSET + j)
        .collect();
    let done = std::sync::atomic::AtomicUsize::new(0);
    let refs: Vec<(u64, Result<CandidateScore>)> = reference_seeds
        .par_iter()
        .map(|&s| {
            let r = twin_run(req.model, steps, s)
                .and_then(|log| score("reference", Some(s), &log, (&seeds, &prepared), &copts))
                .map(|(c, _)| c);
            let k = done.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1;
            if let Ok(c) = &r {
                progress(&format!(
                    "judge: reference {k}/{} (seed {s}): {} of {} runs differ, mean loss {:.2}",
                    reference_seeds.len(),
                    c.fails[0],
                    sims.len(),
                    c.mean_loss
                ));
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
        return Err(Error::Analysis(format!(
            "judge: {} of {} reference runs completed: too few for a p-value ({})",
            references.len(),
            opts.references,
            notes.join("; ")
        )));
    }
    notes.push(format!(
        "p-values are Monte Carlo ranks among {} reference runs: none is below {:.3}",
        references.len(),
        1.0 / (references.len() + 1) as f64
    ));
    let n_sims = sims.len() as f64;
    let mut criteria: Vec<CriterionTest> = names
        .iter()
        .enumerate()
        .map(|(k, name)| {
            let reference_fails: Vec<usize> = references.iter().map(|c| c.fails[k]).collect();
            let as_f = |v: &[usize]| v.iter().map(|x| *x as f64).collect::<Vec<_>>();
            CriterionTest {
                criterion: name.clone(),
                real_fails: real_score.fails[k],
                reference_rate: drive_sim_analysis::stats::mean(&as_f(&reference_fails)) / n_sims,
                p: monte_carlo_p(real_score.fails[k] as f64, &as_f(&reference_fails)),
                reference_fails,
                p_holm: f64::NAN,
            }
        })
        .collect();
    let rest: Vec<f64> = criteria.iter().skip(1).map(|c| c.p).collect();
    for (c, a) in criteria.iter_mut().skip(1).zip(holm(&rest)) {
        c.p_holm = a;
    }
    criteria[0].p_holm = criteria[0].p;
    let ref_losses: Vec<f64> = references.iter().map(|c| c.mean_loss).collect();
    let loss = LossTest {
        real: real_score.mean_loss,
        p: monte_carlo_p(real_score.mean_loss, &ref_losses),
        references: ref_losses,
    };
    // The Monte Carlo test's rule: reject when p <= alpha (with 19 references and alpha 0.05,
    // when the real run is the most extreme of the 20; exact size alpha under the hypothesis).
    let indistinguishable = loss.p > opts.alpha;
    let short_on = criteria
        .iter()
        .skip(1)
        .filter(|c| c.p_holm <= opts.alpha)
        .map(|c| c.criterion.clone())
        .collect();
    let flagged = criteria
        .iter()
        .skip(1)
        .filter(|c| c.p <= opts.alpha)
        .map(|c| c.criterion.clone())
        .collect();
    progress(&format!(
        "judge: {} (the loss's p {:.3}, the verdict's {:.3})",
        if indistinguishable {
            "indistinguishable from the twin's own runs"
        } else {
            "distinguishable from the twin's own runs"
        },
        loss.p,
        criteria[0].p
    ));
    Ok(JudgeOutcome {
        dataset: real.meta.name.clone(),
        robot: real.meta.robot.clone(),
        options: *opts,
        real_steps_analysed: n_real,
        steps_per_run: steps,
        sim_seeds: seeds,
        reference_seeds: references.iter().filter_map(|c| c.seed).collect(),
        criteria,
        loss,
        indistinguishable,
        short_on,
        flagged,
        real: real_score,
        references,
        notes,
        intervals: Vec::new(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn monte_carlo_p_by_hand() {
        // 4 references, 2 of them at least 3: (1 + 2) / 5.
        assert!((monte_carlo_p(3.0, &[1.0, 3.0, 5.0, 2.0]) - 0.6).abs() < 1e-12);
        // Beyond every reference: the smallest p, 1 / 5.
        assert!((monte_carlo_p(9.0, &[1.0, 3.0, 5.0, 2.0]) - 0.2).abs() < 1e-12);
        // Below every reference: 1.
        assert_eq!(monte_carlo_p(0.0, &[1.0, 3.0, 5.0, 2.0]), 1.0);
        // Non-finite references do not count.
        assert!((monte_carlo_p(3.0, &[1.0, f64::NAN, 5.0]) - 2.0 / 3.0).abs() < 1e-12);
        assert!(monte_carlo_p(3.0, &[f64::NAN]).is_nan());
    }

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
