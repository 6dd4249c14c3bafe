//! Stage 2: cheap screening of the candidates with the kinematic model, so that the
//! simulator fits only the few that can matter.

use super::candidates::{evaluate, Candidate, CandidateEvidence, EvaluateInput};
use super::Context;
use crate::calibration::fit::fit;
use crate::calibration::model::{KinematicFactory, ModelParams, PlantFactory};
use crate::error::Result;
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
}

/// Output of [`run`].
pub struct ScreeningOutput {
    /// The report.
    pub report: ScreeningReport,
    /// The shortlisted candidates, warm-started.
    pub shortlist: Vec<Candidate>,
}

/// Fits the kinematic model's base parameters, then each candidate it can represent with
/// those refit beside it, and keeps the `screen_keep` best by validation reduction (any
/// reduction: the two models differ, so the simulator judges) plus every contact effect.
pub fn run(ctx: &Context<'_>, input: ScreeningInput<'_>) -> Result<ScreeningOutput> {
    let kin = KinematicFactory;
    let specs = kin.base_params(input.declared);
    let (base, _) = fit(&ctx.train, &kin, input.declared, &specs, &ctx.floor, &ctx.opts.fit, &mut |_| {})?;
    let base_validation = ctx.validation.errors(&kin, &base)?;
    let kinematic_validation_score =
        crate::calibration::metrics::score(&base_validation, &ctx.floor);
    let (screened, contact): (Vec<Candidate>, Vec<Candidate>) = input
        .candidates
        .iter()
        .cloned()
        .partition(|c| c.effects.iter().all(|&e| kin.supports(crate::effects::REGISTRY[e])));
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
    let report = ScreeningReport {
        kinematic_validation_score,
        ranking: out.ranked.into_iter().map(|(e, _)| e).collect(),
        shortlist: shortlist.iter().map(|c| c.name.clone()).collect(),
    };
    (ctx.progress)(&format!(
        "screening with the kinematic model ({} candidates, its validation score {:.2}): passing on {}",
        screened.len(),
        kinematic_validation_score,
        report.shortlist.join(", ")
    ));
    Ok(ScreeningOutput { report, shortlist })
}
