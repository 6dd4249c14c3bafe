//! Discovery: from a residual the catalogue cannot explain, to an equation, to a model term.
//!
//! After selection, the current model's residual on the training steps is diagnosed
//! ([`crate::diagnosis`]). The flagged channels are taken where they act, upstream
//! first — the wheels (encoders), then the body (vx, vy, wz), then the IMU — because a missing
//! wheel effect also shows in the body channels, and a body one in the IMU. For each flagged
//! quantity, the residual (recording − model) is regressed on a library of features the model
//! can compute while it runs ([`drive_sim_model::effects::Feature`]: its command, its own state from the
//! replay, time in the step, step index, previous command), never on the measurement it
//! explains; [`crate::discovery::discover`] finds a sparse equation (threshold chosen on the
//! validation steps, terms kept by stability selection over bootstrap resamples by step).
//!
//! An equation becomes candidates: the generic term it describes ([`drive_sim_model::effects::term`],
//! started at the regression's coefficients) and the catalogue's structural effects its
//! structure points to (a constant in vy: a lateral drift). Each is fitted and judged like any
//! catalogue effect ([`super::candidates::evaluate`]: validation reduction with bootstrap
//! evidence, identifiable parameters); when a structural effect scores within one standard
//! error of the best, it is kept instead (a physical effect generalises where a fitted
//! polynomial may not). Rounds repeat until nothing flagged is explained.
//!
//! The catalogue and the terms then compete as two orders ([`super::competition`]).

use super::candidates::{evaluate, Candidate, CandidateEvidence, EvaluateInput};
use super::proposals::{propose, pruned_term, Proposals, ProposeInput, SOURCES};
use super::Context;
use crate::diagnosis::{diagnose, Diagnosis};
use crate::discovery::Equation;
use crate::error::Result;
use crate::events::CalibrationEvent;
use crate::metrics::{StepErrors, StepFeatures};
use crate::model::ModelParams;
use crate::params::ParamSpec;
use drive_sim_model::effects::TermTarget;
use serde::{Deserialize, Serialize};

/// Discovery rounds at most.
const MAX_ROUNDS: usize = 3;
/// The equations' terms of one stage are also tried together (the two wheels' terms of one
/// effect) when they have at most this many coefficients in all. Past it the fit costs a
/// replay of the training steps per coefficient per iteration (about 600 replays for the 24
/// coefficients of warthog_asphalt's two wheel equations), and no measured run's final model
/// kept one.
pub(super) const MAX_JOINT_COEFFICIENTS: usize = 12;
/// An equation explaining less than this share of the validation residual's energy
/// (uncentred R²) is not tried: it fits the training steps, not the effect.
pub const MIN_VALIDATION_R2: f64 = 0.2;

/// The equation found for one model quantity.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FoundEquation {
    /// The quantity it corrects (`body_vy`, `wheel_left`, ...).
    pub target: String,
    /// The residual channels it was fitted on.
    pub channels: Vec<String>,
    /// The equation in readable form (`Δvy = 0.101 (±0.004) · vx·wz`).
    pub text: String,
    /// What its structure suggests, in words.
    pub reading: Vec<String>,
    /// Catalogue effects its structure points to.
    pub suggests: Vec<String>,
    /// The regression.
    pub equation: Equation,
}

/// A quantity with a flagged residual that no equation was fitted for, and why.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SkippedTarget {
    /// The quantity.
    pub target: String,
    /// Why.
    pub reason: String,
}

/// One round of discovery.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DiscoveryRound {
    /// Channels flagged on the training steps at the start of the round.
    pub flagged: Vec<String>,
    /// Where the round looked (`wheel`, `body` or `sensor`).
    pub stage: String,
    /// Equations found.
    pub equations: Vec<FoundEquation>,
    /// Quantities skipped, with the reason.
    pub skipped: Vec<SkippedTarget>,
    /// Candidates tried, ranked by validation reduction.
    pub tried: Vec<CandidateEvidence>,
    /// What was added, if anything.
    pub added: Option<String>,
    /// Why (or why nothing).
    pub why: String,
}

/// What discovery did.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct DiscoveryReport {
    /// Rounds, in order.
    pub rounds: Vec<DiscoveryRound>,
    /// Diagnosis of the model discovery started from, on the training steps.
    pub start: Option<Diagnosis>,
    /// The backward pass after discovery added something: an effect selected earlier as a
    /// stand-in for what discovery found is dropped here.
    #[serde(default)]
    pub backward: Vec<super::selection::BackwardStep>,
    /// Training channels still flagged when discovery ended.
    #[serde(default)]
    pub flagged_after: Vec<String>,
    /// The competition with discovery from the base model, when the catalogue's order left a
    /// channel flagged ([`super::competition`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub competition: Option<Box<super::competition::Competition>>,
}

/// Input of [`run`].
pub struct DiscoveryInput {
    /// The model after selection.
    pub current: ModelParams,
    /// Its validation errors.
    pub current_validation: Vec<StepErrors>,
    /// Effects selected so far.
    pub selected: Vec<Candidate>,
    /// Base parameters refit beside each candidate.
    pub refit: Vec<ParamSpec>,
}

/// Output of [`run`].
pub struct DiscoveryOutput {
    /// What happened.
    pub report: DiscoveryReport,
    /// The model with what was added.
    pub current: ModelParams,
    /// Its validation errors.
    pub current_validation: Vec<StepErrors>,
    /// Effects selected, discovered ones appended.
    pub selected: Vec<Candidate>,
    /// Whether anything was added.
    pub added: bool,
}

/// Runs discovery rounds on top of the current model (see the module doc).
// Long: a round's equations, candidates, evaluation and choice share the round's state.
pub fn run(ctx: &Context<'_>, input: DiscoveryInput) -> Result<DiscoveryOutput> {
    let factory = ctx.factory;
    let mut out = DiscoveryOutput {
        report: DiscoveryReport::default(),
        current: input.current,
        current_validation: input.current_validation,
        selected: input.selected,
        added: false,
    };
    // The flagged channels of the current model on the training steps, when known.
    let mut flagged_now: Option<Vec<String>> = None;
    for round in 0..MAX_ROUNDS {
        let (model_train, diag) = on_training(ctx, &out.current)?;
        if round == 0 {
            out.report.start = Some(diag.clone());
        }
        let flagged: Vec<String> = diag.flagged().iter().map(|s| s.to_string()).collect();
        flagged_now = Some(flagged.clone());
        let stage_of = |t: TermTarget| t.stage().as_str();
        // Upstream first: the stages with a flagged channel, in the order a command meets them.
        let mut stages: Vec<&str> = Vec::new();
        for s in SOURCES
            .iter()
            .filter(|s| s.channels().iter().any(|c| flagged.contains(c)))
        {
            if !stages.contains(&stage_of(s.target)) {
                stages.push(stage_of(s.target));
            }
        }
        if stages.is_empty() {
            break;
        }
        let model_val = ctx.validation.replay_features(factory, &out.current)?;
        let mut added_this_round = false;
        for stage in stages {
            let mut this = DiscoveryRound {
                flagged: flagged.clone(),
                stage: stage.to_string(),
                equations: Vec::new(),
                skipped: Vec::new(),
                tried: Vec::new(),
                added: None,
                why: String::new(),
            };
            let Proposals {
                equations,
                skipped,
                mut candidates,
                structural,
            } = propose(
                ctx,
                &ProposeInput {
                    stage,
                    round,
                    flagged: &flagged,
                    model_train: &model_train,
                    model_val: &model_val,
                    selected: &out.selected,
                },
            );
            this.equations = equations;
            this.skipped = skipped;
            if candidates.is_empty() {
                this.why = "no equation: nothing to try at this stage".into();
                out.report.rounds.push(this);
                continue;
            }
            (ctx.progress)(&CalibrationEvent::DiscoveryRound {
                round: round + 1,
                flagged: flagged.clone(),
                stage: stage.to_string(),
                trying: candidates.iter().map(|c| c.name.clone()).collect(),
            });
            // The effects selected so far are refit beside each candidate: one selected as a
            // stand-in for what the equation describes can let go of it.
            let refit: Vec<ParamSpec> = input
                .refit
                .iter()
                .copied()
                .chain(
                    out.selected
                        .iter()
                        .flat_map(|c| c.params.iter().filter(|p| !p.discrete).copied()),
                )
                .collect();
            let ev = evaluate(
                ctx,
                factory,
                EvaluateInput {
                    current: &out.current,
                    current_validation: &out.current_validation,
                    candidates: &candidates,
                    refit: &refit,
                    seed: ctx.opts.rule.seed.wrapping_add(7000 + round as u64 * 100),
                },
            )?;
            // A term whose fit leaves some coefficients confounded (with the base parameters or
            // an effect refit beside it) is tried once more with only its identifiable
            // coefficients: the regression chose the features on the residual, the replay's
            // fit is what tells which of them the data pin down.
            let pruned: Vec<Candidate> = ev
                .ranked
                .iter()
                .filter(|(e, _)| !e.significant && e.identifiable == Some(false) && e.reduction > 0.0)
                .filter_map(|(e, _)| {
                    let c = candidates[structural..].iter().find(|c| c.name == e.effect)?;
                    pruned_term(c, e)
                })
                .filter(|p| !candidates.iter().any(|c| c.name == p.name))
                .collect();
            let mut ev = ev;
            if !pruned.is_empty() {
                let more = evaluate(
                    ctx,
                    factory,
                    EvaluateInput {
                        current: &out.current,
                        current_validation: &out.current_validation,
                        candidates: &pruned,
                        refit: &refit,
                        seed: ctx.opts.rule.seed.wrapping_add(7050 + round as u64 * 100),
                    },
                )?;
                ev.ranked.extend(more.ranked);
                ev.ranked.sort_by(|a, b| b.0.reduction.total_cmp(&a.0.reduction));
                candidates.extend(pruned);
            }
            this.tried = ev.ranked.iter().map(|(e, _)| e.clone()).collect();
            let Some(best) = ev.ranked.iter().find(|(e, _)| e.significant) else {
                this.why = "no candidate lowered the validation score with bootstrap evidence".into();
                out.report.rounds.push(this);
                continue;
            };
            let best_ev = &best.0;
            // Of the explanations within one standard error of the best, the one with the
            // fewest parameters is kept (a dead time beats a dozen terms that fit the same
            // residual), a structural effect before a generic term of as many, then the larger
            // reduction.
            let is_structural = |name: &str| candidates[..structural].iter().any(|c| c.name == name);
            let (chosen_ev, model) = ev
                .ranked
                .iter()
                .filter(|(e, _)| e.significant)
                .filter(|(e, _)| e.reduction >= best_ev.reduction - best_ev.reduction_se)
                .min_by(|(a, _), (b, _)| {
                    a.params
                        .len()
                        .cmp(&b.params.len())
                        .then(is_structural(&b.effect).cmp(&is_structural(&a.effect)))
                        .then(b.reduction.total_cmp(&a.reduction))
                })
                .unwrap_or(best);
            this.why = if chosen_ev.effect == best_ev.effect {
                format!(
                    "{} lowers the validation score by {:.3} ± {:.3}",
                    chosen_ev.effect, chosen_ev.reduction, chosen_ev.reduction_se
                )
            } else {
                format!(
                    "{} ({} parameters{}) scores within one standard error of {} ({} parameters; {:.3} vs {:.3} ± {:.3}): the explanation with fewer parameters is kept",
                    chosen_ev.effect,
                    chosen_ev.params.len(),
                    if is_structural(&chosen_ev.effect) { ", a physical effect" } else { "" },
                    best_ev.effect,
                    best_ev.params.len(),
                    chosen_ev.reduction,
                    best_ev.reduction,
                    best_ev.reduction_se
                )
            };
            this.added = Some(chosen_ev.effect.clone());
            let Some(candidate) = candidates.iter().find(|c| c.name == chosen_ev.effect).cloned() else {
                out.report.rounds.push(this);
                continue;
            };
            out.current = model.clone();
            out.current_validation = ctx.validation.errors(factory, &out.current)?;
            if is_structural(&candidate.name) {
                // Named effects taken together are judged one by one by the backward pass: a
                // member the data do not need is dropped there.
                out.selected.extend(candidate.members());
            } else {
                out.selected.push(candidate);
            }
            out.added = true;
            added_this_round = true;
            flagged_now = None;
            (ctx.progress)(&CalibrationEvent::DiscoveryAdded {
                effect: chosen_ev.effect.clone(),
            });
            out.report.rounds.push(this);
            break;
        }
        if !added_this_round {
            break;
        }
    }
    if out.added {
        out.report.backward = super::selection::backward_pass(
            ctx,
            &mut out.selected,
            &mut out.current,
            &mut out.current_validation,
        )?;
        if out.report.backward.iter().any(|b| b.dropped) {
            flagged_now = None;
        }
    }
    // The last round's diagnosis holds unless the model changed after it.
    out.report.flagged_after = match flagged_now {
        Some(flagged) => flagged,
        None => {
            let (_, diag) = on_training(ctx, &out.current)?;
            diag.flagged().iter().map(|s| s.to_string()).collect()
        }
    };
    Ok(out)
}

/// `model` replayed on the training steps, and the diagnosis of its residual there.
fn on_training(ctx: &Context<'_>, model: &ModelParams) -> Result<(Vec<StepFeatures>, Diagnosis)> {
    let replayed = ctx.train.replay_features(ctx.factory, model)?;
    let residuals: Vec<_> = replayed
        .iter()
        .zip(&ctx.train.features)
        .map(|(m, r)| crate::metrics::step_residuals(m, r))
        .collect::<Result<_>>()?;
    let diag = diagnose(
        &residuals,
        &ctx.train.features,
        &ctx.floor,
        &ctx.declared.robot.idd(),
    );
    Ok((replayed, diag))
}
