//! The judgements of a twin: `judge` on steps its choice never saw, on the steps of the twin
//! written, on a run left out, and what still differs and why.

use crate::error::Result;
use crate::event::TwinEvent;
use crate::input::{Ground, RunLog};
use crate::pass::PassReport;
use crate::rule::{towards_robot, Choice, MOVES_A_TERM};
use crate::screen::Screening;
use crate::tune::Tuning;
use drive_sim_calibration::ModelParams;
use drive_sim_compare::judge::{self, JudgeOptions, JudgeOutcome, JudgeRequest, YardstickRequest, DIFFERS};
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
        outcome.yardsticks = judge::yardsticks(&YardstickRequest {
            real: log,
            others,
            others_half: None,
            model,
            opts,
            twin_mean_loss: outcome.loss.real,
        })?;
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
///
/// Held out, when the judge tells the twin apart, the robot's own steps of the other half
/// (those the twin was chosen on) are the yardstick: a twin cannot be asked to be closer to
/// the judged half than the robot's other half is. One run's halves may differ by more than the
/// twin's runs do (a split's luck, or variation the model lacks), and the yardstick test says
/// whether they do.
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
    let mut judged = judge_grounds(&items, opts, opts.real_steps != UseSteps::All, progress)?;
    let Some(half) = opts.real_steps.other_half() else {
        return Ok(judged);
    };
    // Only a twin the judge tells apart needs it (19 more runs of the twin): it says whether
    // the robot's own steps would be told apart as well.
    for ((j, g), m) in judged.iter_mut().zip(grounds).zip(models) {
        if j.outcome.indistinguishable {
            continue;
        }
        let mut choosing = half.select(&g.log);
        choosing.meta.name = format!("{} ({} steps)", g.log.meta.name, half.as_str());
        j.outcome.yardsticks = judge::yardsticks(&YardstickRequest {
            real: &g.log,
            others: &[&choosing],
            others_half: Some(half),
            model: m,
            opts,
            twin_mean_loss: j.outcome.loss.real,
        })?;
    }
    Ok(judged)
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
    /// Those of `moved_by` the twin did not tune (the rule left them out, or the check did not
    /// accept the tuning), each with why.
    #[serde(default)]
    pub not_tuned: Vec<String>,
    /// Tuned values that ended on their box's edge.
    pub at_bound: Vec<String>,
    /// The reason, in words.
    pub why: String,
}

/// The loss term a criterion of the judge is about (`None`: outside the loss).
fn term_of(criterion: &str) -> Option<String> {
    if criterion == DIFFERS || criterion == judge::TURN_MEMORY {
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
pub(crate) fn shortfalls(j: &Judgement, label: &str, pass: &PassReport, grounds: usize) -> Vec<Shortfall> {
    let twin = &pass.twin_score;
    let (screening, choice, tuning) = (&pass.screening, &pass.choice, pass.tuning.as_ref());
    let refinement = pass.refinement.as_ref();
    let prefix = |t: &str| {
        if grounds > 1 {
            format!("{}: {t}", j.ground)
        } else {
            t.to_string()
        }
    };
    // Both rounds' tuned values.
    let at_bound: Vec<String> = tuning
        .into_iter()
        .chain(refinement.and_then(|r| r.tuning.as_ref()))
        .flat_map(|t| &t.values)
        .filter(|v| v.at_bound)
        .map(|v| format!("{} = {:.4} on [{}, {}]", v.name, v.chosen, v.lower, v.upper))
        .collect();
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
            // Knobs either round's screening saw move the term the right way.
            let mut moved_by: Vec<String> = Vec::new();
            if let (Some(n), Some(v)) = (&name, value) {
                let screenings = std::iter::once(screening).chain(refinement.map(|r| &r.screening));
                for k in screenings.flat_map(|s| &s.knobs) {
                    // A map's term is a distance: only a decrease moves it the right way.
                    let moves = k.term_change.iter().any(|(m, d)| {
                        m == n && towards_robot(*d, if ratio { 1.0 } else { v }) >= MOVES_A_TERM
                    });
                    if moves && !moved_by.contains(&k.knob.name) {
                        moved_by.push(k.knob.name.clone());
                    }
                }
            }
            let mut tuned = Vec::new();
            let mut not_tuned = Vec::new();
            for k in &moved_by {
                // A knob the first round does not carry was screened again by the second, whose
                // decision is the last word.
                let first = not_tuned_why(k, screening, choice, tuning);
                let why = match (first, refinement) {
                    (Some(_), Some(r)) => not_tuned_why(k, &r.screening, &r.choice, r.tuning.as_ref()),
                    (first, _) => first,
                };
                match why {
                    Some(why) => not_tuned.push(why),
                    None => tuned.push(k.clone()),
                }
            }
            let why = explain(&c.criterion, value, ratio, &tuned, &not_tuned, &at_bound);
            Shortfall {
                ground: j.ground.clone(),
                judgement: label.to_string(),
                criterion: c.criterion.clone(),
                p: c.p,
                term: value,
                moved_by,
                not_tuned,
                at_bound: at_bound.clone(),
                why,
            }
        })
        .collect()
}

/// Why the twin does not carry `knob`'s change, in words (`None`: it was tuned and the check
/// accepted the tuning).
fn not_tuned_why(
    knob: &str,
    screening: &Screening,
    choice: &Choice,
    tuning: Option<&Tuning>,
) -> Option<String> {
    if choice.chosen.iter().any(|k| k == knob) {
        return match tuning {
            Some(t) if t.accepted => None,
            _ => Some(format!(
                "`{knob}` (tuned, but the check on fresh seeds did not accept the tuning)"
            )),
        };
    }
    let why = match choice.considered.iter().find(|c| c.knob == knob) {
        Some(c) => c.why.clone(),
        None => {
            let gain = screening
                .knobs
                .iter()
                .find(|k| k.knob.name == knob)
                .map_or(f64::NAN, |k| k.gain);
            format!("its screening points raised the loss as a whole, gain {gain:.2}")
        }
    };
    Some(format!("`{knob}` (not tuned: {why})"))
}

/// Why a criterion still differs, in words: the knobs tuned that move it the right way, and
/// those the screening saw move it that the twin does not carry.
fn explain(
    criterion: &str,
    value: Option<f64>,
    ratio: bool,
    moved_by: &[String],
    not_tuned: &[String],
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
    if moved_by.is_empty() && not_tuned.is_empty() {
        format!("{side}; no knob of the model moves it towards the robot's: the model lacks an effect or physics there")
    } else if moved_by.is_empty() {
        format!(
            "{side}; the screening moved it the right way with {}, which the twin does not carry",
            not_tuned.join(", ")
        )
    } else {
        let besides = if not_tuned.is_empty() {
            String::new()
        } else {
            format!("; the screening also moved it with {}", not_tuned.join(", "))
        };
        if at_bound.is_empty() {
            format!(
                "{side}; moved the right way by {}, which the search traded against the other terms{besides}",
                moved_by.join(", ")
            )
        } else {
            format!(
                "{side}; moved the right way by {}, and the search ended with {} on a bound: a box too small, or a stand-in for a missing effect{besides}",
                moved_by.join(", "),
                at_bound.join(", ")
            )
        }
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::closed::PointScore;
    use crate::knobs::KnobInfo;
    use crate::rule::Rule;
    use crate::screen::KnobScreen;

    fn knob(name: &str, gain: f64) -> KnobScreen {
        KnobScreen {
            knob: KnobInfo {
                name: name.into(),
                params: vec![name.into()],
                terrain_side: false,
            },
            points: Vec::new(),
            best: Some(0),
            gain,
            term_change: vec![(name.into(), -1.0)],
        }
    }

    #[test]
    fn a_knob_the_screening_saw_move_a_criterion_is_named_with_why_the_twin_lacks_it() {
        let screening = Screening {
            seeds: vec![0, 1],
            start: PointScore {
                loss: Some(10.0),
                seed_losses: vec![Some(10.0); 2],
                terms: Vec::new(),
                error: None,
            },
            knobs: vec![knob("scatter", 3.0), knob("icr", -0.4), knob("drift", 0.5)],
            runs: 0,
        };
        let choice = Rule::default().choose(&screening, 1, 1.0);
        assert_eq!(choice.chosen, vec!["scatter"]);
        // Tuned but not accepted, left out by the rule, and worse as a whole.
        assert!(not_tuned_why("scatter", &screening, &choice, None)
            .unwrap()
            .contains("did not accept"));
        let drift = not_tuned_why("drift", &screening, &choice, None).unwrap();
        assert!(drift.contains("not tuned") && drift.contains("below"), "{drift}");
        let icr = not_tuned_why("icr", &screening, &choice, None).unwrap();
        assert!(icr.contains("raised the loss as a whole, gain -0.40"), "{icr}");

        let only_untuned = explain(
            "slip_vy_m_s map",
            Some(1.2),
            true,
            &[],
            std::slice::from_ref(&icr),
            &[],
        );
        assert!(
            only_untuned.contains("which the twin does not carry"),
            "{only_untuned}"
        );
        assert!(!only_untuned.contains("lacks an effect"), "{only_untuned}");
        let both = explain("median_rho", Some(-1.3), false, &["scatter".into()], &[icr], &[]);
        assert!(
            both.contains("moved the right way by scatter") && both.contains("also moved it with `icr`"),
            "{both}"
        );
        let none = explain("median_rho", Some(-1.3), false, &[], &[], &[]);
        assert!(none.contains("the model lacks an effect"), "{none}");
    }
}
