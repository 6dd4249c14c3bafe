//! The judgements of a twin: `judge` on steps its choice never saw, on the steps of the twin
//! written, on a run left out, and what still differs and why.

use crate::closed::PointScore;
use crate::error::Result;
use crate::event::TwinEvent;
use crate::input::{Ground, RunLog};
use crate::screen::Screening;
use crate::tune::Tuning;
use drive_sim_calibration::ModelParams;
use drive_sim_compare::judge::{self, JudgeOptions, JudgeOutcome, JudgeRequest, DIFFERS};
use drive_sim_log::{DriveLog, UseSteps};
use serde::{Deserialize, Serialize};

/// Offset of the judgements' seeds from the command's (`tune`'s judging offset): the twin's
/// runs judged are not the runs its choice was made on.
pub const JUDGE_SEED_OFFSET: u64 = drive_sim_compare::tune::JUDGE_SEED_OFFSET;

/// One judgement of a ground's twin.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Judgement {
    /// The ground.
    pub ground: String,
    /// The real run (or pooled runs) judged against.
    pub against: String,
    /// Its steps judged: `even` (held out), `all`.
    pub steps: String,
    /// The steps judged played no part in choosing the twin.
    pub held_out: bool,
    /// `judge`'s outcome (with the other real runs of the ground as yardsticks, when given).
    pub outcome: JudgeOutcome,
}

/// Judges each ground's twin against the steps `steps` of its log; `held_out` says whether
/// those steps played a part in the choice. `others` are, per ground, other real runs of it
/// (the robot's own difference beside the twin's).
pub(crate) fn judge_grounds(
    grounds: &[(&str, &DriveLog, &ModelParams, Vec<&DriveLog>)],
    opts: &JudgeOptions,
    held_out: bool,
    progress: &(dyn Fn(&TwinEvent) + Sync),
) -> Result<Vec<Judgement>> {
    let steps = opts.real_steps;
    let mut out = Vec::new();
    for (ground, log, model, others) in grounds {
        let what = format!(
            "the {ground} twin against {} of {}{}",
            steps_text(steps.as_str()),
            log.meta.name,
            if held_out {
                " (never used to choose it)"
            } else {
                ""
            }
        );
        progress(&TwinEvent::Judging { what: &what });
        let mut outcome = judge::judge(
            &JudgeRequest {
                real: log,
                model,
                opts,
            },
            &|_| {},
        )?;
        for other in others {
            let y = judge::yardstick(log, other, opts, outcome.loss.real)?;
            outcome.yardsticks.push(y);
        }
        progress(&TwinEvent::Judged {
            what: &what,
            outcome: &outcome,
        });
        out.push(Judgement {
            ground: ground.to_string(),
            against: log.meta.name.clone(),
            steps: steps.as_str().to_string(),
            held_out,
            outcome,
        });
    }
    Ok(out)
}

/// The held-out or final judgements of every ground's twin against its own (pooled) runs.
pub(crate) fn judge_own_grounds(
    grounds: &[Ground],
    models: &[ModelParams],
    opts: &JudgeOptions,
    progress: &(dyn Fn(&TwinEvent) + Sync),
) -> Result<Vec<Judgement>> {
    let items: Vec<(&str, &DriveLog, &ModelParams, Vec<&DriveLog>)> = grounds
        .iter()
        .zip(models)
        .map(|(g, m)| (g.name.as_str(), &g.log, m, Vec::new()))
        .collect();
    judge_grounds(&items, opts, opts.real_steps != UseSteps::All, progress)
}

/// A twin made without one run, judged on it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LeftOut {
    /// The run left out.
    pub run: String,
    /// The runs the twin was made from.
    pub made_from: Vec<String>,
    /// The judgement on every step of the run left out, with the runs of its ground that made
    /// the twin as yardsticks (`None` when no other run is on its ground: the twin has no
    /// terrain for it).
    pub judgement: Option<Judgement>,
    /// Why there is no judgement.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub note: Option<String>,
}

/// Judges the twin made from `rest` (its grounds and models) on the run `left`.
pub(crate) fn judge_left_out(
    runs: &[RunLog],
    left: usize,
    rest: (&[Ground], &[ModelParams]),
    opts: &JudgeOptions,
    progress: &(dyn Fn(&TwinEvent) + Sync),
) -> Result<Option<Judgement>> {
    let log = &runs[left].log;
    let Some(g) = rest.0.iter().position(|g| g.name == log.meta.terrain) else {
        return Ok(None);
    };
    let others: Vec<&DriveLog> = rest.0[g].runs.iter().map(|&i| &runs[i].log).collect();
    let item = [(rest.0[g].name.as_str(), log, &rest.1[g], others)];
    Ok(judge_grounds(&item, opts, true, progress)?.pop())
}

/// A criterion the twin still fails, and why.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Shortfall {
    /// The ground.
    pub ground: String,
    /// The judgement it comes from (`held out`, `final`).
    pub judgement: String,
    /// The criterion (`median_rho`, `t_area_pct_wheels`, `slip_wz_rad_s map`, ...).
    pub criterion: String,
    /// Its Monte Carlo p-value (uncorrected).
    pub p: f64,
    /// The twin's loss term for it on the check's seeds (sim − real in threshold units; a
    /// map's is its RMS over the yardstick), when the loss has one.
    pub term: Option<f64>,
    /// Knobs whose screening moved that term towards the robot's by at least a quarter of a
    /// threshold.
    pub moved_by: Vec<String>,
    /// Tuned values that ended on their box's edge.
    pub at_bound: Vec<String>,
    /// The reason, in words.
    pub why: String,
}

/// The loss term a criterion of the judge is about (`None`: outside the loss).
fn term_of(criterion: &str) -> Option<String> {
    if criterion == DIFFERS || criterion == judge::STEP_SCATTER || criterion == judge::TURN_MEMORY {
        return None;
    }
    if let Some(channel) = criterion.strip_suffix(" map") {
        return Some(channel.to_string());
    }
    if criterion.starts_with("t_area") {
        return Some(format!("{criterion}/tolerance"));
    }
    Some(criterion.to_string())
}

/// What a pass leaves for one judgement: the criteria it flags, each with the twin's term,
/// the knobs that move it the right way and the values on their bound.
pub(crate) fn shortfalls(
    j: &Judgement,
    label: &str,
    twin: &PointScore,
    screening: &Screening,
    tuning: Option<&Tuning>,
    grounds: usize,
) -> Vec<Shortfall> {
    let prefix = |t: &str| {
        if grounds > 1 {
            format!("{}: {t}", j.ground)
        } else {
            t.to_string()
        }
    };
    let at_bound: Vec<String> = tuning
        .map(|t| {
            t.values
                .iter()
                .filter(|v| v.at_bound)
                .map(|v| format!("{} = {:.4} on [{}, {}]", v.name, v.chosen, v.lower, v.upper))
                .collect()
        })
        .unwrap_or_default();
    j.outcome
        .criteria
        .iter()
        .filter(|c| c.p <= j.outcome.options.alpha)
        .map(|c| {
            let name = term_of(&c.criterion).map(|t| prefix(&t));
            let value = name
                .as_ref()
                .and_then(|n| twin.terms.iter().find(|(m, _)| m == n).map(|(_, v)| *v));
            let ratio = c.criterion.ends_with(" map");
            let moved_by: Vec<String> = match (&name, value) {
                (Some(n), Some(v)) => screening
                    .knobs
                    .iter()
                    .filter(|k| {
                        k.term_change
                            .iter()
                            .any(|(m, d)| m == n && if ratio || v > 0.0 { *d <= -0.25 } else { *d >= 0.25 })
                    })
                    .map(|k| k.knob.name.clone())
                    .collect(),
                _ => Vec::new(),
            };
            let why = explain(&c.criterion, value, ratio, &moved_by, &at_bound);
            Shortfall {
                ground: j.ground.clone(),
                judgement: label.to_string(),
                criterion: c.criterion.clone(),
                p: c.p,
                term: value,
                moved_by,
                at_bound: at_bound.clone(),
                why,
            }
        })
        .collect()
}

/// Why a criterion still differs, in words.
fn explain(
    criterion: &str,
    value: Option<f64>,
    ratio: bool,
    moved_by: &[String],
    at_bound: &[String],
) -> String {
    let Some(v) = value else {
        return format!(
            "`{criterion}` is outside compare's loss (or has no term on these steps): the search does not aim at it"
        );
    };
    let side = if ratio {
        format!("the maps differ by {v:.2} times their tolerance")
    } else if v > 0.0 {
        format!("the twin's is above the robot's ({v:+.2} thresholds)")
    } else {
        format!("the twin's is below the robot's ({v:+.2} thresholds)")
    };
    if moved_by.is_empty() {
        format!("{side}; no knob of the model moves it towards the robot's: the model lacks an effect or physics there")
    } else if !at_bound.is_empty() {
        format!(
            "{side}; moved the right way by {}, and the search ended with {} on a bound: a box too small, or a stand-in for a missing effect",
            moved_by.join(", "),
            at_bound.join(", ")
        )
    } else {
        format!(
            "{side}; moved the right way by {}, which the search traded against the other terms",
            moved_by.join(", ")
        )
    }
}

/// Which steps (`odd`, `even`, `all`), in words: "the odd steps", "every step".
pub(crate) fn steps_text(steps: &str) -> String {
    if steps == UseSteps::All.as_str() {
        "every step".into()
    } else {
        format!("the {steps} steps")
    }
}
