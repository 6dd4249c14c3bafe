//! What discovery proposes at one stage of one round: for each flagged quantity, the
//! regression of its residual on the feature library ([`crate::discovery::discover`]), and from
//! each equation the candidates it gives — its generic term, the named effects its reading
//! points to (started where the equation reads them), every equation's terms together and every
//! equation's named effects together. [`super::discovery`] evaluates and chooses among them.

use super::candidates::{Candidate, CandidateEvidence};
use super::discovery::{FoundEquation, SkippedTarget, MAX_JOINT_COEFFICIENTS, MIN_VALIDATION_R2};
use super::reading::{read, text_of, Reading};
use super::Context;
use crate::data::StepSet;
use crate::discovery::{discover, DiscoveryOptions, Equation, Library, Rows};
use crate::metrics::StepFeatures;
use crate::params::{Param, ParamSpec};
use drive_sim_model::effects::{self, Feature, TermInput, TermTarget};
use drive_sim_model::kinematics::IdealDiffDrive;

/// Channels (diagnosis names, and index in the steady / series arrays) a target is fitted on.
pub(super) struct Source {
    pub(super) target: TermTarget,
    steady: Option<usize>,
    series: Option<usize>,
}

pub(super) const SOURCES: [Source; 6] = [
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
    pub(super) fn channels(&self) -> Vec<String> {
        use crate::metrics::{SERIES_CHANNELS, STEADY_CHANNELS};
        self.steady
            .map(|c| format!("steady {}", STEADY_CHANNELS[c]))
            .into_iter()
            .chain(self.series.map(|c| format!("transient {}", SERIES_CHANNELS[c])))
            .collect()
    }
}

/// Input of [`propose`].
pub(super) struct ProposeInput<'a> {
    /// The stage looked at (`wheel`, `body`, `sensor`).
    pub stage: &'a str,
    /// The round (seeds the regression's resamples).
    pub round: usize,
    /// Channels flagged on the training steps.
    pub flagged: &'a [String],
    /// The current model replayed on the training steps.
    pub model_train: &'a [StepFeatures],
    /// ... and on the validation steps.
    pub model_val: &'a [StepFeatures],
    /// Effects selected so far (not proposed again).
    pub selected: &'a [Candidate],
}

/// Output of [`propose`].
pub(super) struct Proposals {
    /// Equations found, with their readings.
    pub equations: Vec<FoundEquation>,
    /// Quantities flagged that no equation was kept for, and why.
    pub skipped: Vec<SkippedTarget>,
    /// Candidates: the named effects (and their groups) first, then the generic terms.
    pub candidates: Vec<Candidate>,
    /// How many of `candidates` are named effects.
    pub structural: usize,
}

/// The equations and candidates of one stage (see the module doc).
pub(super) fn propose(ctx: &Context<'_>, input: &ProposeInput<'_>) -> Proposals {
    let factory = ctx.factory;
    let idd = ctx.declared.robot.idd();
    let mut equations: Vec<FoundEquation> = Vec::new();
    let mut skipped: Vec<SkippedTarget> = Vec::new();
    let mut candidates: Vec<Candidate> = Vec::new();
    let mut terms: Vec<Candidate> = Vec::new();
    let mut together: Vec<Vec<String>> = Vec::new();
    for src in SOURCES
        .iter()
        .filter(|s| s.target.stage().as_str() == input.stage)
    {
        if !src.channels().iter().any(|c| input.flagged.contains(c)) {
            continue;
        }
        let library = library_of(src.target);
        let train_rows = rows_of(src, &ctx.train, input.model_train, &idd, ctx);
        let val_rows = rows_of(src, &ctx.validation, input.model_val, &idd, ctx);
        let opts = DiscoveryOptions {
            seed: ctx.opts.seed ^ (input.round as u64 * 31 + src.target as u64),
            ..DiscoveryOptions::default()
        };
        match discover(&library, &train_rows, &val_rows, &opts) {
            Err(skip) => skipped.push(SkippedTarget {
                target: src.target.name().into(),
                reason: skip.reason,
            }),
            Ok(eq) if !eq.terms.is_empty() && eq.validation_r2 < MIN_VALIDATION_R2 => {
                skipped.push(SkippedTarget {
                    target: src.target.name().into(),
                    reason: format!(
                        "its equation {} explains {:.0} % of the validation residual (less than {:.0} %)",
                        text_of(src.target, &eq),
                        100.0 * eq.validation_r2,
                        100.0 * MIN_VALIDATION_R2
                    ),
                })
            }
            Ok(eq) if eq.terms.is_empty() => skipped.push(SkippedTarget {
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
                    let selected = input.selected.iter().any(|c| c.name == *s);
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
                equations.push(FoundEquation {
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
    Proposals {
        equations,
        skipped,
        candidates,
        structural,
    }
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
pub(super) fn pruned_term(c: &Candidate, ev: &CandidateEvidence) -> Option<Candidate> {
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
