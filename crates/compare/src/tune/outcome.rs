//! What a tuning found (`tune.json`), and the check's rule.

use super::*;

/// One tuned parameter.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TunedParam {
    /// Report name (`effect.motor_stall_torque_nm`, `terrain.friction.peak_lateral`).
    pub name: String,
    /// Unit.
    pub unit: String,
    /// Search box.
    pub lower: f64,
    /// Search box.
    pub upper: f64,
    /// The start model's value (`None`: the effect is off there).
    pub start: Option<f64>,
    /// Where the search started: the start model's value when inside the box, else the box's
    /// starting point.
    pub search_start: f64,
    /// The search's best.
    pub chosen: f64,
    /// The best lies in the outer half percent of the box (a likely stand-in for something
    /// the model lacks, or a box too small).
    pub at_bound: bool,
}

/// One point of the search.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PointEvaluation {
    /// Parameter values, in the order of `params`.
    pub values: Vec<f64>,
    /// Mean loss over the seeds; `None` when a run failed.
    pub loss: Option<f64>,
    /// Loss of each seed's run.
    pub seed_losses: Vec<Option<f64>>,
    /// Why a run failed.
    pub error: Option<String>,
}

/// The check of the choice on fresh seeds.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SeedCheck {
    /// Seeds.
    pub seeds: Vec<u64>,
    /// Loss of the start model per seed (`None`: the run failed).
    pub start: Vec<Option<f64>>,
    /// Loss of the chosen model per seed.
    pub chosen: Vec<Option<f64>>,
    /// Mean of (start − chosen) over the seeds where both ran.
    pub mean_reduction: f64,
    /// Its standard error (sample standard deviation / √n).
    pub se: f64,
    /// The rule's outcome.
    pub accepted: bool,
    /// The rule, in words.
    pub rule: String,
}

/// One judged run: its loss and what `compare` says against the held-out steps.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct JudgedRun {
    /// Seed.
    pub seed: u64,
    /// Loss (the search's measure) against the held-out steps.
    pub loss: Option<Loss>,
    /// Scalar metrics (sim − real, intervals, Holm).
    pub metrics: Vec<MetricDiff>,
    /// Transfer-function ratios.
    pub transfer: Vec<TfDiff>,
    /// Verdict.
    pub verdict: Option<Verdict>,
    /// Why the run failed.
    pub error: Option<String>,
}

/// The judgement of the start and the chosen model on real steps, with fresh seeds: the steps
/// the choice did not see (`heldout`), or, when it saw every step, those (`same_steps`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct HeldOut {
    /// The held-out steps.
    pub steps: UseSteps,
    /// Analysed real steps in them.
    pub real_steps: usize,
    /// The start model, one run per judging seed.
    pub start: Vec<JudgedRun>,
    /// The chosen model, on the same seeds.
    pub chosen: Vec<JudgedRun>,
    /// The real run's choosing half compared with its held-out half as if it were a simulated
    /// run (`seed` 0: not a run): how far a model that matched the choosing half exactly would
    /// be from the held-out one. Where the halves differ beyond a tolerance (a T/U area by more
    /// than 5 pp), no model meets it on both. `None` when judged on the choosing steps.
    pub real_halves: Option<JudgedRun>,
    /// Each judging seed's comparison (both models against the held-out steps), for the
    /// figures and `report.html`.
    #[serde(skip)]
    pub reports: Vec<ComparisonReport>,
}

/// Everything [`tune`] found (`tune.json`).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct TuneOutcome {
    /// The real log.
    pub dataset: String,
    /// Its robot.
    pub robot: String,
    /// Options.
    pub options: TuneOptions,
    /// Analysed real steps the choice used.
    pub real_steps_chosen_on: usize,
    /// DRIVE steps of each simulated run.
    pub steps_per_run: u32,
    /// Seeds of the search.
    pub choose_seeds: Vec<u64>,
    /// Parameters, start and chosen.
    pub params: Vec<TunedParam>,
    /// Every point evaluated, in order (the loss landscape).
    pub evaluations: Vec<PointEvaluation>,
    /// The search.
    pub search: SearchSummary,
    /// Mean loss of the start on the search's seeds.
    pub start_loss: Option<f64>,
    /// The start model's runs on the search's seeds (its values: the start model's, NaN where
    /// an effect is off).
    pub start_evaluation: PointEvaluation,
    /// Mean loss of the chosen point on the search's seeds.
    pub chosen_loss: f64,
    /// The check on fresh seeds.
    pub check: SeedCheck,
    /// The judgement on the other half (`None` when the choice used every step).
    pub heldout: Option<HeldOut>,
    /// When the choice used every step: the judgement on those same steps with fresh seeds
    /// (a twin judged against the run it was made from; not held out).
    #[serde(default)]
    pub same_steps: Option<HeldOut>,
    /// The twin is the chosen model (the check accepted it), not the start.
    pub accepted: bool,
    /// What happened, in words.
    pub notes: Vec<String>,
    /// The twin's model: the chosen one when accepted, else the start.
    #[serde(skip)]
    pub model: Option<ModelParams>,
}

/// The check's rule on paired losses (start, chosen) per seed: the chosen model is accepted
/// when every one of its runs completes and its mean loss reduction exceeds twice its standard
/// error (`same_point`: the choice is the start, nothing to accept).
pub fn check_rule(
    seeds: Vec<u64>,
    start: Vec<Option<f64>>,
    chosen: Vec<Option<f64>>,
    same_point: bool,
) -> SeedCheck {
    let d: Vec<f64> = start
        .iter()
        .zip(&chosen)
        .filter_map(|(a, b)| match (a, b) {
            (Some(a), Some(b)) => Some(a - b),
            // A start that fails where the choice runs: the choice is the better model there.
            (None, Some(_)) => Some(f64::INFINITY),
            _ => None,
        })
        .collect();
    let n = d.len() as f64;
    let finite: Vec<f64> = d.iter().copied().filter(|v| v.is_finite()).collect();
    let mean = if d.iter().any(|v| v.is_infinite()) {
        f64::INFINITY
    } else {
        finite.iter().sum::<f64>() / n.max(1.0)
    };
    let se = if finite.len() >= 2 {
        drive_sim_analysis::stats::mean_sd(&finite).1 / (finite.len() as f64).sqrt()
    } else {
        f64::NAN
    };
    let every_chosen_ran = chosen.iter().all(Option::is_some);
    let accepted = !same_point && every_chosen_ran && d.len() >= 2 && mean > 0.0 && mean > 2.0 * se;
    SeedCheck {
        seeds,
        start,
        chosen,
        mean_reduction: mean,
        se,
        accepted,
        rule: "accepted when every run of the chosen model completes and its mean loss reduction over the fresh seeds, paired by seed, exceeds twice its standard error".into(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_check_accepts_only_a_reduction_beyond_two_standard_errors() {
        let s = |v: &[f64]| v.iter().map(|x| Some(*x)).collect::<Vec<_>>();
        let c = check_rule(vec![1, 2, 3], s(&[10.0, 11.0, 12.0]), s(&[5.0, 6.0, 6.5]), false);
        assert!(c.accepted, "{c:?}");
        assert!((c.mean_reduction - 5.1666).abs() < 1e-3);
        // Noisy: one seed better, one worse.
        let c = check_rule(
            vec![1, 2, 3],
            s(&[10.0, 11.0, 12.0]),
            s(&[5.0, 14.0, 11.0]),
            false,
        );
        assert!(!c.accepted, "{c:?}");
        // The same point (the start was the best) is never "accepted".
        let c = check_rule(vec![1, 2], s(&[10.0, 11.0]), s(&[10.0, 11.0]), true);
        assert!(!c.accepted);
        // A choice whose run fails is not accepted, however good the others.
        let c = check_rule(
            vec![1, 2, 3],
            s(&[10.0, 11.0, 12.0]),
            vec![Some(1.0), None, Some(1.0)],
            false,
        );
        assert!(!c.accepted);
    }
}
