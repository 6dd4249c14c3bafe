//! Stage 2: cheap screening of the candidates with the kinematic model, so that the
//! simulator fits only the few that can matter.

use super::candidates::{evaluate, pairs_of, Candidate, CandidateEvidence, EvaluateInput};
use super::Context;
use crate::error::Result;
use crate::events::CalibrationEvent;
use crate::fit::fit;
use crate::model::{KinematicFactory, ModelParams, PlantFactory};
use serde::{Deserialize, Serialize};

/// Input of [`run`].
pub struct ScreeningInput<'m> {
    /// Every candidate of the calibrated model.
    pub candidates: &'m [Candidate],
    /// The declared model (the kinematic model starts from its robot).
    pub declared: &'m ModelParams,
}

/// What screening found.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ScreeningReport {
    /// The kinematic model's own validation score after its base fit.
    pub kinematic_validation_score: f64,
    /// Candidates the kinematic model can represent, ranked by its validation reduction.
    pub ranking: Vec<CandidateEvidence>,
    /// Candidates passed on to the simulator (the best few of the ranking, warm-started from
    /// their kinematic fit, and the contact effects the kinematic model cannot represent).
    pub shortlist: Vec<String>,
    /// Pairs of the best candidates it can represent, ranked by its validation reduction.
    #[serde(default)]
    pub pair_ranking: Vec<CandidateEvidence>,
    /// Pairs passed on to the simulator's first round (the best few of `pair_ranking`).
    #[serde(default)]
    pub pair_shortlist: Vec<String>,
}

/// Output of [`run`].
pub struct ScreeningOutput {
    /// The report.
    pub report: ScreeningReport,
    /// The shortlisted candidates, warm-started.
    pub shortlist: Vec<Candidate>,
    /// The shortlisted pairs, warm-started: the only pairs the simulator tries.
    pub pairs: Vec<Candidate>,
}

/// Pairs passed on to the simulator: a pair costs the simulator as much as two singles, and
/// the kinematic model ranks them as well as it ranks singles.
const PAIRS_KEPT: usize = 2;

/// Fits the kinematic model's base parameters, then each candidate it can represent with
/// those refit beside it, and keeps the `screen_keep` best by validation reduction (any
/// reduction: the two models differ, so the simulator judges) plus every contact effect.
/// Then the pairs among its `pair_top` best, of which the best two (`PAIRS_KEPT`) go on: the
/// simulator's first round tries those instead of every pair of its own top candidates (which
/// cost it six simulator fits, most of its selection time on `warthog_gravel`). Pairs with a
/// contact effect are not tried: the pairs are for effects that only pay together, such as a
/// controller's gain with its wheel limit, which the kinematic model represents.
pub fn run(ctx: &Context<'_>, input: ScreeningInput<'_>) -> Result<ScreeningOutput> {
    let kin = KinematicFactory;
    let specs = kin.base_params(input.declared);
    let (base, _) = fit(
        &ctx.train,
        &kin,
        input.declared,
        &specs,
        &ctx.floor,
        &ctx.opts.fit,
        &mut |_| {},
    )?;
    let base_validation = ctx.validation.errors(&kin, &base)?;
    let kinematic_validation_score = crate::metrics::score(&base_validation, &ctx.floor);
    let (screened, contact): (Vec<Candidate>, Vec<Candidate>) =
        input.candidates.iter().cloned().partition(|c| {
            c.effects
                .iter()
                .all(|&e| kin.supports(drive_sim_model::effects::REGISTRY[e]))
        });
    let out = evaluate(
        ctx,
        &kin,
        EvaluateInput {
            current: &base,
            current_validation: &base_validation,
            candidates: &screened,
            refit: &specs,
            seed: ctx.opts.rule.seed ^ ctx.opts.seed ^ 0x5c4e,
        },
    )?;
    let mut shortlist: Vec<Candidate> = out
        .ranked
        .iter()
        .filter(|(e, _)| e.reduction > 0.0)
        .take(ctx.opts.screen_keep)
        .filter_map(|(e, m)| {
            screened
                .iter()
                .find(|c| c.name == e.effect)
                .map(|c| c.warm_from(m))
        })
        .collect();
    shortlist.extend(contact);
    let top: Vec<Candidate> = out
        .ranked
        .iter()
        .filter(|(e, _)| e.reduction > 0.0)
        .take(ctx.opts.pair_top)
        .filter_map(|(e, m)| {
            screened
                .iter()
                .find(|c| c.name == e.effect)
                .map(|c| c.warm_from(m))
        })
        .collect();
    let tried = pairs_of(&top.iter().collect::<Vec<_>>());
    let pairs_out = if ctx.opts.pair_top >= 2 && !tried.is_empty() {
        evaluate(
            ctx,
            &kin,
            EvaluateInput {
                current: &base,
                current_validation: &base_validation,
                candidates: &tried,
                refit: &specs,
                seed: ctx.opts.rule.seed ^ ctx.opts.seed ^ 0x5c4f,
            },
        )?
        .ranked
    } else {
        Vec::new()
    };
    let pairs: Vec<Candidate> = pairs_out
        .iter()
        .filter(|(e, _)| e.reduction > 0.0)
        .take(PAIRS_KEPT)
        .filter_map(|(e, m)| tried.iter().find(|c| c.name == e.effect).map(|c| c.warm_from(m)))
        .collect();
    let report = ScreeningReport {
        kinematic_validation_score,
        ranking: out.ranked.into_iter().map(|(e, _)| e).collect(),
        shortlist: shortlist.iter().map(|c| c.name.clone()).collect(),
        pair_ranking: pairs_out.into_iter().map(|(e, _)| e).collect(),
        pair_shortlist: pairs.iter().map(|c| c.name.clone()).collect(),
    };
    (ctx.progress)(&CalibrationEvent::Screening {
        candidates: screened.len(),
        pairs: report.pair_ranking.len(),
        validation_score: kinematic_validation_score,
        shortlist: report.shortlist.clone(),
        pair_shortlist: report.pair_shortlist.clone(),
    });
    Ok(ScreeningOutput {
        report,
        shortlist,
        pairs,
    })
}
