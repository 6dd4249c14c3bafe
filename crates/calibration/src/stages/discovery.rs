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
use super::reading::{read, text_of, Reading};
use super::Context;
use crate::data::StepSet;
use crate::diagnosis::{diagnose, Diagnosis};
use crate::discovery::{discover, DiscoveryOptions, Equation, Library, Rows};
use crate::error::Result;
use crate::events::CalibrationEvent;
use crate::metrics::{StepErrors, StepFeatures};
use crate::model::ModelParams;
use crate::params::{Param, ParamSpec};
use drive_sim_model::effects::{self, Feature, TermInput, TermTarget};
use drive_sim_model::kinematics::IdealDiffDrive;
use serde::{Deserialize, Serialize};

/// Discovery rounds at most.
const MAX_ROUNDS: usize = 3;
/// The equations' terms of one stage are also tried together (the two wheels' terms of one
/// effect) when they have at most this many coefficients in all. Past it the fit costs a
/// replay of the training steps per coefficient per iteration (about 600 replays for the 24
/// coefficients of warthog_asphalt's two wheel equations), and no measured run's final model
/// kept one.
const MAX_JOINT_COEFFICIENTS: usize = 12;
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

/// Channels (diagnosis names, and index in the steady / series arrays) a target is fitted on.
struct Source {
    target: TermTarget,
    steady: Option<usize>,
    series: Option<usize>,
}

const SOURCES: [Source; 6] = [
    Source {
        target: TermTarget::WheelLeft,
        steady: Some(3),
        series: Some(2),
    },
    Source {
        target: TermTarget::WheelRight,
        steady: Some(4),
        series: Some(3),
    },
    Source {
        target: TermTarget::BodyVx,
        steady: Some(0),
        series: Some(0),
    },
    Source {
        target: TermTarget::BodyVy,
        steady: Some(1),
        series: None,
    },
    Source {
        target: TermTarget::BodyWz,
        steady: Some(2),
        series: Some(1),
    },
    Source {
        target: TermTarget::ImuWz,
        steady: Some(5),
        series: None,
    },
];

impl Source {
    fn channels(&self) -> Vec<String> {
        use crate::metrics::{SERIES_CHANNELS, STEADY_CHANNELS};
        self.steady
            .map(|c| format!("steady {}", STEADY_CHANNELS[c]))
            .into_iter()
            .chain(self.series.map(|c| format!("transient {}", SERIES_CHANNELS[c])))
            .collect()
    }
}

/// Runs discovery rounds on top of the current model (see the module doc).
// Long: a round's equations, candidates, evaluation and choice share the round's state.
pub fn run(ctx: &Context<'_>, input: DiscoveryInput) -> Result<DiscoveryOutput> {
    let factory = ctx.factory;
    let idd = ctx.declared.robot.idd();
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
            let mut candidates: Vec<Candidate> = Vec::new();
            let mut terms: Vec<Candidate> = Vec::new();
            let mut together: Vec<Vec<String>> = Vec::new();
            for src in SOURCES.iter().filter(|s| stage_of(s.target) == stage) {
                if !src.channels().iter().any(|c| flagged.contains(c)) {
                    continue;
                }
                let library = library_of(src.target);
                let train_rows = rows_of(src, &ctx.train, &model_train, &idd, ctx);
                let val_rows = rows_of(src, &ctx.validation, &model_val, &idd, ctx);
                let opts = DiscoveryOptions {
                    seed: ctx.opts.seed ^ (round as u64 * 31 + src.target as u64),
                    ..DiscoveryOptions::default()
                };
                match discover(&library, &train_rows, &val_rows, &opts) {
                    Err(skip) => this.skipped.push(SkippedTarget {
                        target: src.target.name().into(),
                        reason: skip.reason,
                    }),
                    Ok(eq) if !eq.terms.is_empty() && eq.validation_r2 < MIN_VALIDATION_R2 => {
                        this.skipped.push(SkippedTarget {
                            target: src.target.name().into(),
                            reason: format!(
                                "its equation {} explains {:.0} % of the validation residual (less than {:.0} %)",
                                text_of(src.target, &eq),
                                100.0 * eq.validation_r2,
                                100.0 * MIN_VALIDATION_R2
                            ),
                        })
                    }
                    Ok(eq) if eq.terms.is_empty() => this.skipped.push(SkippedTarget {
                        target: src.target.name().into(),
                        reason: format!(
                            "no stable term in the library explains it (validation RMS {:.2} floors)",
                            eq.validation_rms[0]
                        ),
                    }),
                    Ok(eq) => {
                        let Reading {
                            text: reading,
                            suggests,
                            starts,
                        } = read(src.target, &eq);
                        let term = term_candidate(src.target, &eq);
                        let mut named_here: Vec<String> = Vec::new();
                        for s in &suggests {
                            let selected = out.selected.iter().any(|c| c.name == *s);
                            let listed = candidates.iter().any(|c| c.name == *s);
                            if let Some(i) = effects::REGISTRY.iter().position(|e| e.name() == *s) {
                                let e = effects::REGISTRY[i];
                                if !selected && factory.supports(e) {
                                    if !listed {
                                        candidates.push(Candidate::of_effect(i, &ctx.reach).started_at(&starts));
                                    }
                                    if e.stage() == src.target.stage() {
                                        named_here.push(s.clone());
                                    }
                                }
                            }
                        }
                        if named_here.len() > 1 {
                            together.push(named_here);
                        }
                        this.equations.push(FoundEquation {
                            target: src.target.name().into(),
                            channels: src.channels(),
                            text: text_of(src.target, &eq),
                            reading,
                            suggests,
                            equation: eq,
                        });
                        terms.push(term);
                    }
                }
            }
            if terms.len() > 1 {
                let all = terms[1..]
                    .iter()
                    .fold(terms[0].clone(), |acc, t| Candidate::pair(&acc, t));
                if all.params.len() <= MAX_JOINT_COEFFICIENTS {
                    terms.push(all);
                }
            }
            let joint = named_together(&candidates, &together);
            candidates.extend(joint);
            let structural = candidates.len();
            candidates.extend(terms);
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

/// The named effects each equation reads, as one candidate per equation: the physical
/// counterpart of its term when its structure has several parts (a turning centre off the
/// origin and a centripetal slip), which one effect alone cannot match. `groups` holds each
/// equation's effect names; a group already among `candidates` is not repeated.
fn named_together(candidates: &[Candidate], groups: &[Vec<String>]) -> Vec<Candidate> {
    let mut out: Vec<Candidate> = Vec::new();
    for names in groups {
        let members: Vec<&Candidate> = names
            .iter()
            .filter_map(|n| candidates.iter().find(|c| c.name == *n))
            .collect();
        if members.len() < 2 {
            continue;
        }
        let joint = members[1..]
            .iter()
            .fold(members[0].clone(), |acc, c| Candidate::pair(&acc, c));
        if !candidates.iter().chain(&out).any(|c| c.name == joint.name) {
            out.push(joint);
        }
    }
    out
}

/// `c`, a discovered term (or several taken together), with only the coefficients its fit
/// found identifiable; `None` when none is, or all are.
fn pruned_term(c: &Candidate, ev: &CandidateEvidence) -> Option<Candidate> {
    let keep = |s: &ParamSpec| {
        ev.params
            .iter()
            .find(|p| p.name == s.param.name())
            .is_some_and(|p| p.identifiable == Some(true) && !p.confounded)
    };
    let params: Vec<ParamSpec> = c.params.iter().copied().filter(|s| keep(s)).collect();
    if params.is_empty() || params.len() == c.params.len() {
        return None;
    }
    // Each target with a coefficient left, and its features.
    let mut parts: Vec<(TermTarget, Vec<&'static str>)> = Vec::new();
    for s in &params {
        let name = s.param.name();
        let Some((target, feature)) = TermTarget::ALL.iter().find_map(|t| {
            let f = name.strip_prefix(&format!("effect.term_{}__", t.name()))?;
            Some((*t, Feature::from_name(f)?))
        }) else {
            continue;
        };
        match parts.iter_mut().find(|(t, _)| *t == target) {
            Some((_, fs)) => fs.push(feature.symbol()),
            None => parts.push((target, vec![feature.symbol()])),
        }
    }
    let effects = c
        .effects
        .iter()
        .copied()
        .filter(|&i| {
            parts
                .iter()
                .any(|(t, _)| effects::REGISTRY[i].name() == t.effect_name())
        })
        .collect();
    Some(Candidate {
        name: parts
            .iter()
            .map(|(t, fs)| format!("term {} = {}", t.name(), fs.join(" + ")))
            .collect::<Vec<_>>()
            .join("+"),
        effects,
        params,
    })
}

/// The library of a target: every feature it has, the intercept first.
fn library_of(target: TermTarget) -> Library {
    let f = target.features();
    Library {
        names: f.iter().map(|f| f.name().to_string()).collect(),
        intercept: f.iter().position(|f| *f == Feature::One),
    }
}

/// The regression rows of one target: the residual (recording − model) of each channel it is
/// fitted on, divided by the channel's floor, with the features computed from the model's
/// replay and the command at the same place.
fn rows_of(
    src: &Source,
    set: &StepSet<'_>,
    model: &[StepFeatures],
    idd: &IdealDiffDrive,
    ctx: &Context<'_>,
) -> Rows {
    let target = src.target;
    let features = target.features();
    let mut rows = Rows::default();
    for ((meas, m), start) in set.features.iter().zip(model).zip(&set.starts) {
        let cmd = meas.cmd;
        let base = TermInput::at_step(&start.context(meas.step), cmd, idd);
        // Per sample: the model's own velocity and acceleration (central differences).
        let n = m.series.len();
        let at = |i: usize| -> Vec<f64> {
            let mut x = base;
            x.t_in_step_s = m.t_s[i];
            x.body.vx_m_s = m.series[i][0];
            x.body.wz_rad_s = m.series[i][1];
            let (a, b) = (i.saturating_sub(1), (i + 1).min(n - 1));
            let dt = m.t_s[b] - m.t_s[a];
            if dt > 0.0 && m.window[a] == m.window[b] {
                x.accel = [
                    (m.series[b][0] - m.series[a][0]) / dt,
                    (m.series[b][1] - m.series[a][1]) / dt,
                ];
            }
            features.iter().map(|f| f.value(&x, target.side())).collect()
        };
        if let Some(c) = src.steady {
            let w = 1.0 / ctx.floor.steady[c];
            for (k, (sm, mm)) in meas.steady.iter().zip(&m.steady).enumerate() {
                let window = k as u32 + 1;
                let idx: Vec<usize> = (0..n).filter(|&i| m.window[i] == window).collect();
                if idx.is_empty() {
                    continue;
                }
                // A recording without an IMU has no imu_wz to explain.
                if (sm[c] - mm[c]).is_nan() {
                    continue;
                }
                let mut x = vec![0.0; features.len()];
                for &i in &idx {
                    for (acc, v) in x.iter_mut().zip(at(i)) {
                        *acc += v / idx.len() as f64;
                    }
                }
                rows.push(sm[c] - mm[c], x, w, meas.step);
            }
        }
        if let Some(c) = src.series {
            let w = 1.0 / ctx.floor.series[c];
            for i in (0..n.min(meas.series.len())).filter(|&i| meas.window[i] == 0) {
                rows.push(meas.series[i][c] - m.series[i][c], at(i), w, meas.step);
            }
        }
    }
    rows
}

/// The generic-term candidate of an equation: its coefficients, each searched in a box
/// around the regression's estimate.
fn term_candidate(target: TermTarget, eq: &Equation) -> Candidate {
    let effect = effects::REGISTRY
        .iter()
        .position(|e| e.name() == target.effect_name())
        .unwrap_or(0);
    let params = eq
        .terms
        .iter()
        .filter_map(|t| {
            let f = Feature::from_name(&t.feature)?;
            let param = Param::effect_param(&target.key(f))?;
            let c = t.coefficient;
            let half = c.abs().max(2.0 * (t.ci95[1] - t.ci95[0])).max(1e-6);
            let mut s = ParamSpec::new(param, c - 2.0 * half, c + 2.0 * half);
            s.start = c;
            Some(s)
        })
        .collect();
    Candidate {
        name: format!(
            "term {} = {}",
            target.name(),
            eq.terms
                .iter()
                .map(|t| Feature::from_name(&t.feature).map_or(t.feature.as_str(), |f| f.symbol()))
                .collect::<Vec<_>>()
                .join(" + ")
        ),
        effects: vec![effect],
        params,
    }
}
