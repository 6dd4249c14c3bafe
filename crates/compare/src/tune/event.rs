//! What [`super::tune`] tells its caller as it goes: one event per phase and per point of the
//! search, each displayed as the line `drive-sim tune` prints for it.

use super::search::SearchSummary;
use super::{HeldOut, JudgedRun, PointEvaluation, SeedCheck};
use drive_sim_log::UseSteps;
use std::fmt;

/// What [`tune`](super::tune) tells its caller as it goes. `Display` gives the line
/// `drive-sim tune` prints (after its clock).
#[derive(Debug, Clone, Copy)]
pub enum TuneEvent<'a> {
    /// Every input is checked and the choosing steps are analysed: the runs start.
    Started {
        /// The real log's name.
        dataset: &'a str,
        /// The steps the choice uses.
        choose_on: UseSteps,
        /// How many of them the analysis keeps.
        real_steps: usize,
        /// Parameters tuned.
        params: usize,
        /// DRIVE steps of each run.
        steps_per_run: u32,
        /// Seeds each point is run with.
        seeds: usize,
        /// Most points the search evaluates.
        max_points: usize,
    },
    /// The start model on the search's seeds (the baseline of the search's losses).
    StartModel {
        /// Its runs' losses (its values: the start model's).
        point: &'a PointEvaluation,
    },
    /// One point of the search evaluated.
    Point {
        /// Its number, from 1, in the order evaluated.
        index: usize,
        /// The tuned parameters' keys, in the order of the point's values.
        keys: &'a [String],
        /// Its values and losses.
        point: &'a PointEvaluation,
        /// The smallest loss so far, this point's included (infinite while every run failed).
        best: f64,
    },
    /// The search stopped.
    SearchDone {
        /// How it went.
        summary: &'a SearchSummary,
        /// The tuned parameters' keys.
        keys: &'a [String],
        /// The best point's values.
        best: &'a [f64],
        /// Its mean loss.
        loss: f64,
        /// The start model's (`None`: a run failed).
        start_loss: Option<f64>,
    },
    /// The check on fresh seeds decided.
    Checked {
        /// The check.
        check: &'a SeedCheck,
    },
    /// Both models judged on real steps with fresh seeds.
    Judged {
        /// The judgement.
        judgement: &'a HeldOut,
    },
}

/// The values of a point, `key=value` in 4 decimals, space-separated.
fn values(keys: &[String], x: &[f64]) -> String {
    keys.iter()
        .zip(x)
        .map(|(k, v)| format!("{k}={v:.4}"))
        .collect::<Vec<_>>()
        .join(" ")
}

/// A mean loss in 2 decimals, or why a run failed.
fn loss_or_failure(point: &PointEvaluation) -> String {
    point.loss.map_or_else(
        || format!("failed ({})", point.error.clone().unwrap_or_default()),
        |l| format!("{l:.2}"),
    )
}

/// Mean loss of the judged runs that have one.
fn mean_judged_loss(runs: &[JudgedRun]) -> f64 {
    let v: Vec<f64> = runs
        .iter()
        .filter_map(|r| r.loss.as_ref().map(|l| l.total))
        .collect();
    v.iter().sum::<f64>() / v.len().max(1) as f64
}

impl fmt::Display for TuneEvent<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            TuneEvent::Started {
                dataset,
                choose_on,
                real_steps,
                params,
                steps_per_run,
                seeds,
                max_points,
            } => write!(
                f,
                "tune: {params} parameter(s) on {real_steps} {} steps of `{dataset}`, {steps_per_run} DRIVE steps x {seeds} seed(s) per point, at most {max_points} points",
                choose_on.as_str()
            ),
            TuneEvent::StartModel { point } => {
                write!(f, "tune: the start model: loss {}", loss_or_failure(point))
            }
            TuneEvent::Point {
                index,
                keys,
                point,
                best,
            } => write!(
                f,
                "tune: point {index} {} -> loss {} (best {best:.2})",
                values(keys, &point.values),
                loss_or_failure(point)
            ),
            TuneEvent::SearchDone {
                summary,
                keys,
                best,
                loss,
                start_loss,
            } => write!(
                f,
                "tune: search done ({} points, {}): best {} loss {loss:.2} (start {})",
                summary.evaluations,
                summary.stop,
                values(keys, best),
                start_loss.map_or_else(|| "failed".into(), |l| format!("{l:.2}"))
            ),
            TuneEvent::Checked { check } => write!(
                f,
                "tune: check on {} fresh seeds: loss reduction {:.2} ± {:.2} (SE): {}",
                check.seeds.len(),
                check.mean_reduction,
                check.se,
                if check.accepted {
                    "accepted"
                } else {
                    "not accepted, the twin stays the start"
                }
            ),
            TuneEvent::Judged { judgement: h } => write!(
                f,
                "tune: judged on the {} {} steps{} ({} seeds): mean loss start {:.2}, chosen {:.2}",
                h.real_steps,
                h.steps.as_str(),
                if h.real_halves.is_some() {
                    ""
                } else {
                    " it was chosen on (not held out)"
                },
                h.start.len(),
                mean_judged_loss(&h.start),
                mean_judged_loss(&h.chosen)
            ),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The lines are the ones `drive-sim tune` has always printed for these phases.
    #[test]
    fn events_display_as_the_printed_lines() {
        let started = TuneEvent::Started {
            dataset: "warthog_gravel",
            choose_on: UseSteps::Odd,
            real_steps: 50,
            params: 1,
            steps_per_run: 20,
            seeds: 1,
            max_points: 3,
        };
        assert_eq!(
            started.to_string(),
            "tune: 1 parameter(s) on 50 odd steps of `warthog_gravel`, 20 DRIVE steps x 1 seed(s) per point, at most 3 points"
        );
        let keys = vec!["a".to_string(), "b".to_string()];
        let mut point = PointEvaluation {
            values: vec![12.7, 0.5],
            loss: Some(5.0691),
            seed_losses: vec![Some(5.0691)],
            error: None,
        };
        let event = TuneEvent::Point {
            index: 2,
            keys: &keys,
            point: &point,
            best: 5.0691,
        };
        assert_eq!(
            event.to_string(),
            "tune: point 2 a=12.7000 b=0.5000 -> loss 5.07 (best 5.07)"
        );
        point.loss = None;
        point.error = Some("diverged".into());
        assert_eq!(
            TuneEvent::StartModel { point: &point }.to_string(),
            "tune: the start model: loss failed (diverged)"
        );
        let summary = SearchSummary {
            design_points: 1,
            evaluations: 2,
            simplex_iterations: 0,
            stop: "no budget left for the simplex".into(),
            converged: false,
        };
        let done = TuneEvent::SearchDone {
            summary: &summary,
            keys: &keys[..1],
            best: &[12.7],
            loss: 5.0691,
            start_loss: None,
        };
        assert_eq!(
            done.to_string(),
            "tune: search done (2 points, no budget left for the simplex): best a=12.7000 loss 5.07 (start failed)"
        );
    }
}
