//! The robot against itself: another real run of the same robot on the same ground, compared
//! with the judged real steps exactly as each of the twin's runs is.
//!
//! A twin cannot be asked to be closer to a run than the robot is to its own other runs. Two
//! real runs differ by chance, and by what changed between the days (tyres, battery, the
//! ground), which the judge's references do not hold: they are the twin's own runs, whose only
//! spread is the seed's. When the robot's other run is itself called "differs", the judge's
//! test asks the twin to be closer to the run than the robot is. This stage measures that
//! distance in the judge's own currency (compare's loss and verdict) and tests against it:
//!
//! - the other run's loss against the judged steps, beside the twin's runs' mean loss;
//! - the **yardstick test**: the twin runs `references` DRIVE runs of its own, each as long as
//!   the other run (its analysed steps: a T/U area is a hull, which grows with the steps), seeds
//!   `seed..`, each drawn in the quadrants of the other run's commands ([`super::ReferenceRuns`])
//!   and compared with the judged steps as the other run is. When the other run is
//!   the judged run's other half, each of the twin's is the same half of a run as long as the
//!   judged run, drawn as the robot's was ([`super::ReferenceRuns`] says why). If the twin were as
//!   close to the judged run as the robot's other day, the other run's loss would be one more
//!   draw among the twin's runs' losses, and its rank uniform. The twin is **farther** than
//!   the robot itself when the other run's loss is among the smallest: the Monte Carlo p-value
//!   `(1 + #{twin runs with loss ≤ the other's}) / (runs + 1)` (Barnard 1963), rejected at
//!   `alpha` (with 19 runs and 0.05: the other run closer than every run of the twin).
//!
//! The test does not replace the judge's verdict: a twin can be told from the run yet be no
//! farther from it than the robot's other day. Both are reported.

use super::score::monte_carlo_p;
use super::{JudgeOptions, ReferenceRuns};
use crate::error::{Error, Result};
use crate::real_steps::real_steps;
use crate::{compare_prepared_sims, Input, MetricDiff, PreparedReal, PreparedSim};
use drive_sim_calibration::ModelParams;
use drive_sim_log::{DriveLog, UseSteps};
use rayon::prelude::*;
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
    /// The yardstick test's twin runs: DRIVE steps of each (the other run's analysed steps; the
    /// judged run's steps when the other run is its other half, of which the same half is kept).
    #[serde(default)]
    pub twin_run_steps: u32,
    /// The yardstick test's twin runs' losses against the judged steps, in seed order (`seed +
    /// i`); a run that failed is left out (see `twin_runs_failed`).
    #[serde(default)]
    pub twin_run_losses: Vec<f64>,
    /// Twin runs of the yardstick test that failed or gave no loss.
    #[serde(default)]
    pub twin_runs_failed: usize,
    /// The yardstick test's Monte Carlo p-value: small when the other real run is closer to
    /// the judged steps than the twin's runs are (NaN when the other run has no loss).
    #[serde(default)]
    pub p_twin_farther: f64,
    /// The yardstick test does not reject at the judge's `alpha`: the twin is no farther from
    /// the judged steps than the robot's own other run, as far as the test can tell.
    #[serde(default)]
    pub twin_as_close: bool,
}

/// What the yardsticks compare: the judged run, the robot's other runs and the twin.
#[derive(Debug, Clone, Copy)]
pub struct YardstickRequest<'a> {
    /// The judged real log (the options say which of its steps).
    pub real: &'a DriveLog,
    /// Other real runs of the same robot on the same ground.
    pub others: &'a [&'a DriveLog],
    /// The other runs are these steps of the judged run (its other half), not runs of their
    /// own: the twin's runs of the test are then drawn the same way.
    pub others_half: Option<UseSteps>,
    /// The twin.
    pub model: &'a ModelParams,
    /// The judge's options (steps judged, seeds, references, alpha).
    pub opts: &'a JudgeOptions,
    /// The judge's mean loss of the twin's runs against the judged steps (`loss.real`).
    pub twin_mean_loss: f64,
}

/// Compares each other run (all its steps) with the judged steps, with the judge's compare
/// options, and tests the twin's runs against it (see the module doc). Another robot or another
/// ground is bad input naming the other run, refused before any run.
pub fn yardsticks(req: &YardstickRequest) -> Result<Vec<Yardstick>> {
    for other in req.others {
        check_same_ground(req.real, other)?;
    }
    let opts = req.opts;
    let judged = real_steps(req.real, opts.real_steps, "--real-steps", "judge against")?;
    let prepared = PreparedReal::new(
        Input {
            log: &judged.log,
            file: None,
        },
        &opts.compare_options(),
    )?;
    // The twin's runs depend on how they are drawn (their length, the half kept, the commands
    // whose quadrants they draw in): other runs drawn alike share them.
    let mut twin_by_draw: Vec<(ReferenceRuns, TwinLosses)> = Vec::new();
    let mut out = Vec::new();
    for other in req.others {
        let all = real_steps(other, UseSteps::All, "--other-run", "compare with")?;
        let sim = PreparedSim::new(Input {
            log: &all.log,
            file: None,
        })?;
        let report = compare_prepared_sims(&prepared, std::slice::from_ref(&sim))?;
        let steps = all.analysed as u32;
        let draw = match req.others_half {
            Some(half) => ReferenceRuns::half_of(req.real, half),
            None => ReferenceRuns::whole(other, steps),
        };
        let at = match twin_by_draw.iter().position(|(d, _)| *d == draw) {
            Some(at) => at,
            None => {
                let losses = twin_losses(&prepared, req.model, opts, &draw);
                twin_by_draw.push((draw.clone(), losses));
                twin_by_draw.len() - 1
            }
        };
        out.push(one(
            other,
            all.analysed,
            &report.sims[0],
            &twin_by_draw[at].1,
            req,
            draw.steps,
        ));
    }
    Ok(out)
}

/// The twin's runs of the yardstick test against the judged steps.
struct TwinLosses {
    losses: Vec<f64>,
    failed: usize,
}

/// `opts.references` runs of the twin (seeds `seed..`, drawn as `draw` says) compared with the
/// judged steps, in parallel, in seed order.
fn twin_losses(
    prepared: &PreparedReal,
    model: &ModelParams,
    opts: &JudgeOptions,
    draw: &ReferenceRuns,
) -> TwinLosses {
    let runs: Vec<Option<f64>> = (0..opts.references as u64)
        .into_par_iter()
        .map(|i| {
            let log = draw.run(model, opts.seed + i).ok()?;
            let sim = PreparedSim::new(Input {
                log: &log,
                file: None,
            })
            .ok()?;
            let report = compare_prepared_sims(prepared, std::slice::from_ref(&sim)).ok()?;
            report.sims[0].loss.as_ref().map(|l| l.total)
        })
        .collect();
    let losses: Vec<f64> = runs.iter().flatten().copied().filter(|l| l.is_finite()).collect();
    TwinLosses {
        failed: runs.len() - losses.len(),
        losses,
    }
}

fn one(
    other: &DriveLog,
    analysed: usize,
    c: &crate::SimComparison,
    twin: &TwinLosses,
    req: &YardstickRequest,
    steps: u32,
) -> Yardstick {
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
    let p_twin_farther = p_farther(loss, &twin.losses);
    Yardstick {
        other: other.meta.name.clone(),
        other_steps_analysed: analysed,
        loss,
        reproduces: v.reproduces,
        differs_on,
        medians: c
            .metrics
            .iter()
            .filter(|m| m.tolerance.is_none())
            .cloned()
            .collect(),
        twin_mean_loss: req.twin_mean_loss,
        twin_within: loss.is_some_and(|l| req.twin_mean_loss <= l),
        twin_run_steps: steps,
        twin_run_losses: twin.losses.clone(),
        twin_runs_failed: twin.failed,
        p_twin_farther,
        // NaN (no loss for the other run, or no twin run) is no evidence either way: not
        // "as close".
        twin_as_close: p_twin_farther > req.opts.alpha,
    }
}

/// The yardstick test's p-value: the rank of the other run's loss among the twin's runs',
/// the smallest the most extreme (the other run closer than the twin's runs).
pub fn p_farther(other_loss: Option<f64>, twin_losses: &[f64]) -> f64 {
    let negated: Vec<f64> = twin_losses.iter().map(|l| -l).collect();
    other_loss.map_or(f64::NAN, |l| monte_carlo_p(-l, &negated))
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

#[cfg(test)]
mod tests {
    use super::p_farther;

    #[test]
    fn the_other_run_closer_than_every_twin_run_is_the_extreme() {
        let twin: Vec<f64> = (1..=19).map(|k| 4.0 + k as f64).collect();
        // Closer than all 19: p = 1/20, rejected at 0.05.
        assert!((p_farther(Some(3.0), &twin) - 0.05).abs() < 1e-12);
        // Farther than all: p = 1.
        assert!((p_farther(Some(30.0), &twin) - 1.0).abs() < 1e-12);
        // Among them (ties count against the twin's being farther): the rank.
        assert!((p_farther(Some(10.0), &twin) - 7.0 / 20.0).abs() < 1e-12);
        assert!(p_farther(None, &twin).is_nan());
        assert!(p_farther(Some(3.0), &[]).is_nan());
    }

    #[test]
    fn under_the_hypothesis_the_test_rejects_at_its_level() {
        // The other run one more draw among the twin's: each of the 20 ranks once, and the
        // test rejects at 0.05 for exactly one of them.
        let draws: Vec<f64> = (0..20).map(|k| (k as f64 * 0.37).sin() + 2.0).collect();
        let rejected = (0..20)
            .filter(|&k| {
                let rest: Vec<f64> = draws
                    .iter()
                    .enumerate()
                    .filter(|(j, _)| *j != k)
                    .map(|(_, d)| *d)
                    .collect();
                p_farther(Some(draws[k]), &rest) <= 0.05
            })
            .count();
        assert_eq!(rejected, 1);
    }
}
