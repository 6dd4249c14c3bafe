//! Stage 4: which effects enter the model. Forward selection (the best candidate that passes
//! the rule, then the rest re-ranked on top), then pairs among the top candidates (effects that
//! only pay together, such as a controller's speed gain with its wheel limit), then a backward
//! pass that drops any effect whose removal does not hurt the validation score. Every choice is
//! made on the validation steps; every fit on the training steps.

use super::candidates::{
    bootstrap_reduction_se, evaluate, pairs_of, Candidate, CandidateEvidence, EvaluateInput, EvaluateOutput,
};
use super::Context;
use crate::error::Result;
use crate::events::{CalibrationEvent, RoundOutcome};
use crate::fit::fit;
use crate::metrics::{score, StepErrors};
use crate::model::ModelParams;
use crate::params::ParamSpec;
use serde::{Deserialize, Serialize};

/// One round of the forward selection.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SelectionRound {
    /// Round index, from 0.
    pub round: usize,
    /// Candidates ranked by validation reduction, best first.
    pub ranking: Vec<CandidateEvidence>,
    /// The effect added in this round, if any.
    pub added: Option<String>,
}

/// One effect tried out of the model in the backward pass.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BackwardStep {
    /// The effect.
    pub effect: String,
    /// Validation score with it.
    pub score_with: f64,
    /// Validation score without it (the other effects refit).
    pub score_without: f64,
    /// Bootstrap standard error of the difference.
    pub se: f64,
    /// Removed: its removal did not worsen the validation score by more than
    /// `k_se_remove` bootstrap standard errors.
    pub dropped: bool,
}

/// Input of [`run`].
pub struct SelectionInput {
    /// The model effects are added to.
    pub current: ModelParams,
    /// Its validation errors.
    pub current_validation: Vec<StepErrors>,
    /// Candidates.
    pub pool: Vec<Candidate>,
    /// Base parameters refit beside each candidate (empty: effects fitted alone).
    pub refit: Vec<ParamSpec>,
    /// Base parameters of the model (refit with the selected effects after each addition).
    pub base: Vec<ParamSpec>,
    /// The pairs the first round tries, when a screening chose them (the simulator); else the
    /// pairs of the round's own `pair_top` best.
    pub pairs: Option<Vec<Candidate>>,
}

/// Output of [`run`].
pub struct SelectionOutput {
    /// Forward rounds; the first one's ranking is every candidate against the base model.
    pub rounds: Vec<SelectionRound>,
    /// Pairs tried after the forward pass, ranked.
    pub pairs: Vec<CandidateEvidence>,
    /// The backward pass.
    pub backward: Vec<BackwardStep>,
    /// Effects kept, in the order they were added.
    pub selected: Vec<Candidate>,
    /// The model with them.
    pub current: ModelParams,
    /// Its validation errors.
    pub current_validation: Vec<StepErrors>,
    /// What happened, in words.
    pub notes: Vec<String>,
    /// Every fit converged.
    pub converged: bool,
    /// `current` is already the joint fit of the base parameters and every selected effect
    /// (the final fit then only computes the covariance there).
    pub refit_current: bool,
}

struct State {
    /// The current model is the kept joint refit of the base and every selected effect.
    refit_current: bool,
    current: ModelParams,
    validation: Vec<StepErrors>,
    selected: Vec<Candidate>,
    notes: Vec<String>,
    converged: bool,
}

/// Refits the base parameters with every selected effect's continuous parameters, from the
/// current model; kept if the validation score does not get worse.
fn joint_refit(ctx: &Context<'_>, st: &mut State, base: &[ParamSpec], label: &str) -> Result<()> {
    let mut joint: Vec<ParamSpec> = base.to_vec();
    joint.extend(
        st.selected
            .iter()
            .flat_map(|c| c.params.iter().filter(|p| !p.discrete).copied()),
    );
    if joint.is_empty() {
        return Ok(());
    }
    let (m, r) = fit(
        &ctx.train,
        ctx.factory,
        &st.current,
        &joint,
        &ctx.floor,
        &ctx.opts.fit,
        &mut |_| {},
    )?;
    let v = ctx.validation.errors(ctx.factory, &m)?;
    let (old, new) = (score(&st.validation, &ctx.floor), score(&v, &ctx.floor));
    if !r.converged {
        st.converged = false;
        st.notes.push(format!("{label}, joint refit: {}", r.status));
    }
    if new <= old && r.score <= r.initial_score {
        st.current = m;
        st.validation = v;
        st.refit_current = true;
        st.notes.push(format!(
            "{label}, joint refit kept: validation {old:.3} -> {new:.3}"
        ));
    } else {
        st.notes.push(format!(
            "{label}, joint refit discarded: validation {old:.3} -> {new:.3}"
        ));
    }
    Ok(())
}

/// Runs forward selection, pairs and the backward pass.
pub fn run(ctx: &Context<'_>, input: SelectionInput) -> Result<SelectionOutput> {
    let opts = ctx.opts;
    let mut st = State {
        refit_current: false,
        current: input.current.clone(),
        validation: input.current_validation.clone(),
        selected: Vec::new(),
        notes: Vec::new(),
        converged: true,
    };
    let mut pool = input.pool.clone();
    let mut rounds: Vec<SelectionRound> = Vec::new();
    let mut pairs: Vec<CandidateEvidence> = Vec::new();
    // Forward.
    for round in 0..opts.max_effects {
        if round == 1 && opts.rerank_top > 0 {
            pool = rerank(&rounds[0], pool, opts.rerank_top, &mut st.notes);
        }
        if pool.is_empty() {
            break;
        }
        let out = evaluate(
            ctx,
            ctx.factory,
            EvaluateInput {
                current: &st.current,
                current_validation: &st.validation,
                candidates: &pool,
                refit: &input.refit,
                seed: opts.rule.seed ^ opts.seed ^ round as u64,
            },
        )?;
        for (ev, _) in &out.ranked {
            if !ev.converged {
                st.notes
                    .push(format!("round {round}, {}: {}", ev.effect, ev.fit_status));
            }
        }
        let mut best = out.ranked.first().map(|(e, m)| (e.clone(), m.clone()));
        let pair_added = if round == 0 && opts.pair_top >= 2 && opts.max_effects >= 2 {
            first_round_pair(ctx, &st, &input, &out, &pool, &mut best, &mut pairs)?
        } else {
            None
        };
        if let Some((ev, _)) = &best {
            round_event(ctx, round, out.ranked.len(), ev);
        }
        let added = match best {
            Some((ev, model)) if ev.significant => {
                match &pair_added {
                    Some(p) => add_pair(&mut st.selected, &mut pool, p, &model),
                    None => {
                        if let Some(i) = pool.iter().position(|c| c.name == ev.effect) {
                            st.selected.push(pool.remove(i).warm_from(&model));
                        }
                    }
                }
                st.validation = ctx.validation.errors(ctx.factory, &model)?;
                st.current = model;
                st.refit_current = false;
                Some(ev.effect.clone())
            }
            _ => None,
        };
        let stop = added.is_none();
        rounds.push(SelectionRound {
            round,
            ranking: out.ranked.into_iter().map(|(e, _)| e).collect(),
            added,
        });
        if stop {
            break;
        }
        joint_refit(ctx, &mut st, &input.base, &format!("round {round}"))?;
    }
    if opts.pair_top >= 2 && st.selected.len() + 2 <= opts.max_effects {
        last_round_pairs(ctx, &mut st, &input, &rounds, &mut pool, &mut pairs)?;
    }
    // Backward: each selected effect out, the others refit; dropped unless keeping it passes.
    let backward = backward_pass(ctx, &mut st.selected, &mut st.current, &mut st.validation)?;
    if backward.iter().any(|b| b.dropped) {
        st.refit_current = false;
    }
    Ok(SelectionOutput {
        rounds,
        pairs,
        backward,
        selected: st.selected,
        current: st.current,
        current_validation: st.validation,
        notes: st.notes,
        converged: st.converged,
        refit_current: st.refit_current,
    })
}

/// The pool of the rounds after the first: only the best `keep_n` of the first round that
/// lowered the validation score. A candidate that explained nothing against the base model
/// rarely explains something after another effect, and the pairs look for those that only
/// pay together.
fn rerank(
    first: &SelectionRound,
    pool: Vec<Candidate>,
    keep_n: usize,
    notes: &mut Vec<String>,
) -> Vec<Candidate> {
    let added = first.added.clone().unwrap_or_default();
    let keep: Vec<String> = first
        .ranking
        .iter()
        .filter(|e| !added.split('+').any(|a| a == e.effect) && e.reduction > 0.0)
        .take(keep_n)
        .map(|e| e.effect.clone())
        .collect();
    let (kept, rest): (Vec<Candidate>, Vec<Candidate>) =
        pool.into_iter().partition(|c| keep.contains(&c.name));
    notes.push(format!(
        "rounds after the first re-rank the {} best of the first round ({} left out)",
        kept.len(),
        rest.len()
    ));
    kept
}

/// The first round's pairs among its top candidates: two effects that only pay together (a
/// controller's speed gain with its wheel limit) lose to a stand-in when tried one at a time.
/// The best pair replaces `best` (the best single) if it beats the single's model by the
/// selection rule; then it is returned, to be added in the single's place. Every pair tried
/// joins `pairs`.
fn first_round_pair(
    ctx: &Context<'_>,
    st: &State,
    input: &SelectionInput,
    out: &EvaluateOutput,
    pool: &[Candidate],
    best: &mut Option<(CandidateEvidence, ModelParams)>,
    pairs: &mut Vec<CandidateEvidence>,
) -> Result<Option<Candidate>> {
    let opts = ctx.opts;
    let warm: Vec<Candidate> = out
        .ranked
        .iter()
        .filter(|(e, _)| e.reduction > 0.0)
        .filter_map(|(e, m)| pool.iter().find(|c| c.name == e.effect).map(|c| c.warm_from(m)))
        .take(opts.pair_top)
        .collect();
    let tried = match &input.pairs {
        Some(screened) => screened.clone(),
        None => pairs_of(&warm.iter().collect::<Vec<_>>()),
    };
    let Some((single, single_model)) = best.as_ref().filter(|_| !tried.is_empty()) else {
        return Ok(None);
    };
    let pairs_out = evaluate(
        ctx,
        ctx.factory,
        EvaluateInput {
            current: &st.current,
            current_validation: &st.validation,
            candidates: &tried,
            refit: &input.refit,
            seed: opts.rule.seed ^ opts.seed ^ 0x9a0,
        },
    )?;
    let mut added = None;
    if let Some((pev, pmodel)) = pairs_out.ranked.first() {
        let single_val = ctx.validation.errors(ctx.factory, single_model)?;
        let pair_val = ctx.validation.errors(ctx.factory, pmodel)?;
        let gain = score(&single_val, &ctx.floor) - score(&pair_val, &ctx.floor);
        let se = bootstrap_reduction_se(
            &single_val,
            &pair_val,
            &ctx.floor,
            opts.rule.bootstrap_samples,
            opts.seed ^ 0x9a2,
        );
        let better = pev.significant
            && (!single.significant || opts.rule.passes(gain, se, score(&single_val, &ctx.floor)));
        (ctx.progress)(&CalibrationEvent::FirstRoundPairs {
            tried: tried.len(),
            best: pev.effect.clone(),
            validation_before: pev.heldout_before,
            validation_after: pev.heldout_after,
            gain,
            se,
            preferred: better,
        });
        if better {
            added = tried.iter().find(|c| c.name == pev.effect).cloned();
            *best = Some((pev.clone(), pmodel.clone()));
        }
    }
    pairs.extend(pairs_out.ranked.into_iter().map(|(e, _)| e));
    Ok(added)
}

/// Tells the progress observer how a forward round ended.
fn round_event(ctx: &Context<'_>, round: usize, candidates: usize, ev: &CandidateEvidence) {
    (ctx.progress)(&CalibrationEvent::Round {
        round,
        candidates,
        best: ev.effect.clone(),
        validation_before: ev.heldout_before,
        validation_after: ev.heldout_after,
        se: ev.reduction_se,
        outcome: if ev.significant {
            RoundOutcome::Added
        } else if ev.identifiable == Some(false) {
            RoundOutcome::NotIdentifiable
        } else {
            RoundOutcome::NotSignificant
        },
    });
}

/// Pairs among the top candidates of the last forward round that were not added; the best
/// is added if it passes the rule, then the joint refit. Every pair tried joins `pairs`.
fn last_round_pairs(
    ctx: &Context<'_>,
    st: &mut State,
    input: &SelectionInput,
    rounds: &[SelectionRound],
    pool: &mut Vec<Candidate>,
    pairs: &mut Vec<CandidateEvidence>,
) -> Result<()> {
    let opts = ctx.opts;
    let last = rounds.last().map(|r| r.ranking.clone()).unwrap_or_default();
    let top: Vec<&Candidate> = last
        .iter()
        .filter_map(|e| pool.iter().find(|c| c.name == e.effect))
        .take(opts.pair_top)
        .collect();
    let tried = pairs_of(&top);
    if tried.is_empty() {
        return Ok(());
    }
    let out = evaluate(
        ctx,
        ctx.factory,
        EvaluateInput {
            current: &st.current,
            current_validation: &st.validation,
            candidates: &tried,
            refit: &input.refit,
            seed: opts.rule.seed ^ opts.seed ^ 0x9a1,
        },
    )?;
    if let Some((ev, model)) = out.ranked.first() {
        (ctx.progress)(&CalibrationEvent::Pairs {
            tried: tried.len(),
            best: ev.effect.clone(),
            validation_before: ev.heldout_before,
            validation_after: ev.heldout_after,
            se: ev.reduction_se,
            added: ev.significant,
        });
        if ev.significant {
            if let Some(c) = tried.iter().find(|c| c.name == ev.effect) {
                add_pair(&mut st.selected, pool, c, model);
            }
            st.validation = ctx.validation.errors(ctx.factory, model)?;
            st.current = model.clone();
            st.refit_current = false;
            joint_refit(ctx, st, &input.base, "pair")?;
        }
    }
    pairs.extend(out.ranked.into_iter().map(|(e, _)| e));
    Ok(())
}

/// Adds both effects of `pair` to `selected`, warm from `model`, and takes them out of `pool`
/// where they are in it. Each is split from the pair itself: a pair the screening proposed may
/// hold an effect the simulator's pool does not (its singles were not shortlisted), and that
/// effect must still be refit and given an interval with the rest.
fn add_pair(selected: &mut Vec<Candidate>, pool: &mut Vec<Candidate>, pair: &Candidate, model: &ModelParams) {
    for member in pair.members() {
        if let Some(i) = pool.iter().position(|c| c.name == member.name) {
            pool.remove(i);
        }
        selected.push(member.warm_from(model));
    }
}

/// The backward pass: each of `selected` out in turn, the others refit; dropped unless
/// keeping it lowers the validation score by more than `k_se_remove` bootstrap standard
/// errors and `min_rel_remove` of the score ([`super::candidates::SelectionRule::stays`]). Updates the selection, the model and its validation errors.
pub fn backward_pass(
    ctx: &Context<'_>,
    selected: &mut Vec<Candidate>,
    current: &mut ModelParams,
    validation: &mut Vec<StepErrors>,
) -> Result<Vec<BackwardStep>> {
    let opts = ctx.opts;
    let mut backward = Vec::new();
    let mut k = 0;
    while k < selected.len() && selected.len() >= 2 {
        let c = selected[k].clone();
        let neutral: Vec<f64> = c
            .params
            .iter()
            .map(|p| p.param.neutral().unwrap_or(p.start))
            .collect();
        let without = current.with_values(&c.params, &neutral)?;
        let others: Vec<ParamSpec> = selected
            .iter()
            .filter(|o| o.name != c.name)
            .flat_map(|o| o.params.iter().filter(|p| !p.discrete).copied())
            .collect();
        let (m, _) = fit(
            &ctx.train,
            ctx.factory,
            &without,
            &others,
            &ctx.floor,
            &opts.fit,
            &mut |_| {},
        )?;
        let v = ctx.validation.errors(ctx.factory, &m)?;
        let (with_s, without_s) = (score(validation.iter(), &ctx.floor), score(&v, &ctx.floor));
        let se = bootstrap_reduction_se(
            &v,
            validation,
            &ctx.floor,
            opts.rule.bootstrap_samples,
            opts.seed ^ 0xbac ^ k as u64,
        );
        let dropped = !opts.rule.stays(without_s - with_s, se, with_s);
        backward.push(BackwardStep {
            effect: c.name.clone(),
            score_with: with_s,
            score_without: without_s,
            se,
            dropped,
        });
        (ctx.progress)(&CalibrationEvent::Backward {
            effect: c.name.clone(),
            with: with_s,
            without: without_s,
            se,
            dropped,
        });
        if dropped {
            selected.remove(k);
            *current = m;
            *validation = v;
        } else {
            k += 1;
        }
    }
    Ok(backward)
}
