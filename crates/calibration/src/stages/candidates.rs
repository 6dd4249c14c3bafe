//! Candidate effects and the evidence for each: its parameters fitted on the training steps
//! on top of the current model (with the base parameters refit beside them where the model is
//! cheap), then its validation-score reduction with a bootstrap standard error over
//! validation steps, and the identifiability of its parameters.

use super::Context;
use crate::error::Result;
use crate::fit::{fit, FittedParam};
use crate::metrics::{score, NoiseFloor, StepErrors};
use crate::model::{ModelParams, PlantFactory};
use crate::params::ParamSpec;
use drive_sim_model::effects::{CommandReach, REGISTRY};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

/// An effect that may be added to the model, with the parameters fitted when it is tried.
#[derive(Debug, Clone, PartialEq)]
pub struct Candidate {
    /// Name in reports (the registry's effect name; `a+b` for a pair).
    pub name: String,
    /// The registry effects it adds.
    pub effects: Vec<usize>,
    /// Their parameters, search boxes and start values.
    pub params: Vec<ParamSpec>,
}

impl Candidate {
    /// The registry's effect `index` for a log commanding up to `reach`.
    pub fn of_effect(index: usize, reach: &CommandReach) -> Self {
        let e = REGISTRY[index];
        Self {
            name: e.name().to_string(),
            effects: vec![index],
            params: (0..e.params().len())
                .map(|j| ParamSpec::for_effect(index, j, reach))
                .collect(),
        }
    }

    /// Both candidates together.
    pub fn pair(a: &Candidate, b: &Candidate) -> Self {
        Self {
            name: format!("{}+{}", a.name, b.name),
            effects: a.effects.iter().chain(&b.effects).copied().collect(),
            params: a.params.iter().chain(&b.params).copied().collect(),
        }
    }

    /// The single effects of this candidate (itself when it is one), each with its own
    /// parameters: a pair the screening proposed may hold an effect that is not among the
    /// simulator's own candidates, so an added pair is split from itself, not from the pool.
    pub fn members(&self) -> Vec<Candidate> {
        self.effects
            .iter()
            .map(|&e| Candidate {
                name: REGISTRY[e].name().to_string(),
                effects: vec![e],
                params: self
                    .params
                    .iter()
                    .filter(|p| matches!(p.param, crate::params::Param::Effect { effect, .. } if effect == e))
                    .copied()
                    .collect(),
            })
            .collect()
    }

    /// This candidate with the parameters named in `starts` (by key) started there, where
    /// the value lies in their box.
    pub fn started_at(mut self, starts: &[(&str, f64)]) -> Self {
        for p in &mut self.params {
            let key = p.param.key();
            if let Some(&(_, v)) = starts.iter().find(|(k, _)| *k == key) {
                if v.is_finite() && v >= p.lower && v <= p.upper {
                    p.start = v;
                }
            }
        }
        self
    }

    /// This candidate started from the values it has in `model` (a warm start).
    pub fn warm_from(&self, model: &ModelParams) -> Self {
        let mut c = self.clone();
        for p in &mut c.params {
            let v = p.param.get(model);
            if v >= p.lower && v <= p.upper {
                p.start = v;
            }
        }
        c
    }
}

/// The registry indices of the effects switched on in `model` (a robot or terrain file's own
/// `[effects]`, lifted into the starting model).
pub fn declared_effects(model: &ModelParams) -> Vec<usize> {
    model
        .effects
        .active()
        .filter_map(|e| REGISTRY.iter().position(|r| r.name() == e.name()))
        .collect()
}

/// The parameters of the effects the starting model already has, as base parameters: a
/// declared effect (the Warthog's measured wheel-speed limit) is refit on every log, given an
/// interval, and judged ([`crate::DeclaredEffectCheck`]), not proposed again as a
/// candidate. Only the declared parameters (away from their neutral value) are refit; on/off
/// parameters (a sign flip) stay as declared. Each box is the registry's
/// search box for this log's reach, widened to hold the declared value, which is where the
/// search starts.
pub fn declared_specs(model: &ModelParams, reach: &CommandReach) -> Vec<ParamSpec> {
    let mut out = Vec::new();
    for i in declared_effects(model) {
        for (j, def) in REGISTRY[i].params().iter().enumerate() {
            if def.kind == drive_sim_model::effects::ParamKind::Flag {
                continue;
            }
            let mut spec = ParamSpec::for_effect(i, j, reach);
            let v = spec.param.get(model);
            if def.is_neutral(v) || !v.is_finite() {
                // Not declared (a discovered term's unused coefficients, the other side of a
                // one-sided gain): nothing to refit.
                continue;
            }
            spec.lower = spec.lower.min(v);
            spec.upper = spec.upper.max(v);
            spec.start = v;
            out.push(spec);
        }
    }
    out
}

/// Every pair of `top`, in order, except pairs with a sensor effect: pairs are for two
/// effects that only pay together (a controller's speed gain with its wheel limit), and a
/// sensor effect changes what one sensor reports, not the motion the other effect shapes, so it
/// pays alone or not at all (a pair with the IMU sign flip cost the simulator 150 evaluations
/// on `warthog_gravel` and was not preferred).
pub fn pairs_of(top: &[&Candidate]) -> Vec<Candidate> {
    let sensor = |c: &Candidate| {
        c.effects
            .iter()
            .any(|&e| REGISTRY[e].stage() == drive_sim_model::effects::Stage::Sensor)
    };
    let mut pairs = Vec::new();
    for (i, a) in top.iter().enumerate() {
        for b in &top[i + 1..] {
            if !sensor(a) && !sensor(b) {
                pairs.push(Candidate::pair(a, b));
            }
        }
    }
    pairs
}

/// Every registered effect `factory` can run, as candidates for a log commanding up to
/// `reach`, optionally only those named in `only`; and the names of the registered effects
/// left out because the model cannot run them.
pub fn candidates_for(
    factory: &dyn PlantFactory,
    reach: &CommandReach,
    only: Option<&[String]>,
) -> (Vec<Candidate>, Vec<String>) {
    let mut out = Vec::new();
    let mut unsupported = Vec::new();
    for (i, e) in REGISTRY.iter().enumerate() {
        // Generic terms are proposed by equation discovery, not tried from the catalogue.
        if e.generic() {
            continue;
        }
        if !factory.supports(*e) {
            unsupported.push(e.name().to_string());
            continue;
        }
        match only {
            Some(o) if !o.iter().any(|n| n == e.name()) => continue,
            None if !e.default_candidate() => continue,
            _ => {}
        }
        out.push(Candidate::of_effect(i, reach));
    }
    (out, unsupported)
}

/// Bootstrap standard error of the score reduction `score(before) - score(after)` over the
/// same steps: the steps are resampled with replacement (paired: a resample takes a step's
/// errors under both models) and the reduction is recomputed on each resample (seeded).
/// Infinite with fewer than two steps.
pub fn bootstrap_reduction_se(
    before: &[StepErrors],
    after: &[StepErrors],
    floor: &NoiseFloor,
    samples: usize,
    seed: u64,
) -> f64 {
    let n = before.len().min(after.len());
    if n < 2 || samples < 2 {
        return f64::INFINITY;
    }
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut idx = vec![0usize; n];
    let reductions: Vec<f64> = (0..samples)
        .map(|_| {
            idx.iter_mut().for_each(|i| *i = rng.random_range(0..n));
            score(idx.iter().map(|&i| &before[i]), floor) - score(idx.iter().map(|&i| &after[i]), floor)
        })
        .collect();
    let m = reductions.iter().sum::<f64>() / samples as f64;
    (reductions.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (samples - 1) as f64).sqrt()
}

/// When an improvement counts: beyond `k_se` bootstrap standard errors of the validation
/// score difference and beyond `min_rel` of the validation score before (a complexity penalty:
/// an extra parameter must buy a real, not a within-noise, reduction), with every fitted
/// parameter identifiable.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct SelectionRule {
    /// Required reduction in bootstrap standard errors.
    pub k_se: f64,
    /// The backward pass keeps an effect whose removal worsens the validation score by more
    /// than this many bootstrap standard errors (looser than `k_se`, as stepwise regression's
    /// threshold to remove is looser than its threshold to enter: an effect does not flicker
    /// in and out on the same evidence).
    #[serde(default = "default_k_se_remove")]
    pub k_se_remove: f64,
    /// Required relative reduction of the validation score.
    pub min_rel: f64,
    /// The backward pass keeps an effect only if its removal also worsens the validation
    /// score by more than this share of it (looser than `min_rel`, for the same reason as
    /// `k_se_remove`). Without it, an effect a later one made negligible stays: its removal
    /// changes the score by a hair, and the bootstrap standard error of a hair is a hair.
    #[serde(default = "default_min_rel_remove")]
    pub min_rel_remove: f64,
    /// Bootstrap resamples.
    pub bootstrap_samples: usize,
    /// Bootstrap seed.
    pub seed: u64,
}

fn default_k_se_remove() -> f64 {
    1.0
}

fn default_min_rel_remove() -> f64 {
    0.01
}

impl Default for SelectionRule {
    fn default() -> Self {
        Self {
            k_se: 2.0,
            k_se_remove: default_k_se_remove(),
            min_rel: 0.02,
            min_rel_remove: default_min_rel_remove(),
            bootstrap_samples: 1000,
            seed: 0,
        }
    }
}

impl SelectionRule {
    /// Whether a reduction of `reduction ± se` from `before` counts.
    pub fn passes(&self, reduction: f64, se: f64, before: f64) -> bool {
        reduction > self.k_se * se && reduction > self.min_rel * before
    }

    /// Whether an effect whose removal worsens the validation score from `with` by
    /// `worsening ± se` stays in the backward pass.
    pub fn stays(&self, worsening: f64, se: f64, with: f64) -> bool {
        worsening > self.k_se_remove * se && worsening > self.min_rel_remove * with
    }
}

/// The evidence for one candidate effect.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CandidateEvidence {
    /// Candidate name.
    pub effect: String,
    /// Its fitted parameters, with standard errors and identifiability.
    pub params: Vec<FittedParam>,
    /// Training score before and after fitting it.
    pub train_score_before: f64,
    /// Training score after.
    pub train_score_after: f64,
    /// Validation score without it (the field keeps its first name: the steps that judge
    /// candidates are the validation steps, never the test steps).
    pub heldout_before: f64,
    /// Validation score with it.
    pub heldout_after: f64,
    /// `heldout_before - heldout_after`.
    pub reduction: f64,
    /// Bootstrap standard error of the reduction (over validation steps).
    pub reduction_se: f64,
    /// Share of the validation residual above the noise floor it explains:
    /// `reduction / (heldout_before - 1)`, 1 being the floor's score.
    pub share: f64,
    /// Passes the [`SelectionRule`] and every parameter is identifiable.
    pub significant: bool,
    /// Optimizer converged.
    pub converged: bool,
    /// Optimizer status.
    pub fit_status: String,
    /// Every fitted effect parameter is identifiable (`None`: not assessed, e.g. on/off).
    #[serde(default)]
    pub identifiable: Option<bool>,
    /// The model the evidence comes from (`kinematic` in screening, else the calibrated one).
    #[serde(default)]
    pub model: String,
    /// Model evaluations the fit took (each one replay of the training steps).
    #[serde(default)]
    pub evaluations: u64,
}

/// Input of [`evaluate`].
pub struct EvaluateInput<'m> {
    /// The model the candidates are added to.
    pub current: &'m ModelParams,
    /// Its validation errors (what each candidate is compared with).
    pub current_validation: &'m [StepErrors],
    /// The candidates.
    pub candidates: &'m [Candidate],
    /// Base parameters refit beside each candidate (empty: the effect's parameters alone).
    pub refit: &'m [ParamSpec],
    /// Seed of the bootstraps.
    pub seed: u64,
}

/// Output of [`evaluate`]: the evidence for each candidate with the model it produced, ranked
/// by validation reduction, best first.
pub struct EvaluateOutput {
    /// Ranked evidence and models.
    pub ranked: Vec<(CandidateEvidence, ModelParams)>,
}

/// Fits each candidate on top of the current model and measures its evidence.
///
/// Why refit the base parameters beside a candidate: the base fit has already absorbed what
/// it could of a missing effect (a smaller wheel radius into a wider baseline, say); fitting
/// the effect alone on top of that compensation would find no gain, while the nested
/// comparison (base vs base + effect, both fitted) measures what the effect adds.
pub fn evaluate(
    ctx: &Context<'_>,
    factory: &dyn PlantFactory,
    input: EvaluateInput<'_>,
) -> Result<EvaluateOutput> {
    let heldout_before = score(input.current_validation, &ctx.floor);
    let mut ranked = Vec::new();
    for (i, c) in input.candidates.iter().enumerate() {
        let specs: Vec<ParamSpec> = c.params.iter().chain(input.refit).copied().collect();
        let (model, res) = fit(
            &ctx.train,
            factory,
            input.current,
            &specs,
            &ctx.floor,
            &ctx.opts.fit,
            &mut |_| {},
        )?;
        let after = ctx.validation.errors(factory, &model)?;
        let heldout_after = score(&after, &ctx.floor);
        let reduction = heldout_before - heldout_after;
        let se = bootstrap_reduction_se(
            input.current_validation,
            &after,
            &ctx.floor,
            ctx.opts.rule.bootstrap_samples,
            input.seed.wrapping_add(i as u64),
        );
        let params: Vec<FittedParam> = res
            .params
            .iter()
            .filter(|p| c.params.iter().any(|s| s.param.name() == p.name))
            .cloned()
            .collect();
        // The effect is identifiable unless a parameter is confounded (unconstrained, or
        // confused with another), or every assessed parameter is indistinguishable from its
        // neutral value (the data cannot tell the effect from absent).
        let assessed: Vec<&FittedParam> = params.iter().filter(|p| p.identifiable.is_some()).collect();
        let identifiable = (!assessed.is_empty()).then(|| {
            !assessed.iter().any(|p| p.confounded)
                && !assessed.iter().all(|p| p.neutral_in_interval == Some(true))
        });
        let excess = heldout_before - 1.0;
        let significant = ctx.opts.rule.passes(reduction, se, heldout_before)
            && res.score < res.initial_score
            && identifiable != Some(false);
        ranked.push((
            CandidateEvidence {
                effect: c.name.clone(),
                params,
                train_score_before: res.initial_score,
                train_score_after: res.score,
                heldout_before,
                heldout_after,
                reduction,
                reduction_se: se,
                share: if excess > 1e-9 { reduction / excess } else { 0.0 },
                significant,
                converged: res.converged,
                fit_status: res.status,
                identifiable,
                model: factory.name(),
                evaluations: res.evaluations,
            },
            model,
        ));
    }
    ranked.sort_by(|a, b| b.0.reduction.total_cmp(&a.0.reduction));
    Ok(EvaluateOutput { ranked })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A pair splits back into its two effects, each with its own parameters only (a pair
    /// of a two-parameter effect and a one-parameter one).
    #[test]
    fn a_pair_splits_into_its_members() {
        let reach = CommandReach {
            wheel_rad_s: 10.0,
            speed_m_s: 2.0,
            yaw_rate_rad_s: 1.0,
        };
        let index = |name: &str| REGISTRY.iter().position(|e| e.name() == name).expect(name);
        let a = Candidate::of_effect(index("controller_kinematics"), &reach);
        let b = Candidate::of_effect(index("body_lag"), &reach);
        assert_eq!(a.params.len(), 2);
        let members = Candidate::pair(&a, &b).members();
        assert_eq!(members, vec![a.clone(), b.clone()]);
        assert_eq!(a.members(), vec![a]);
    }

    /// Pairs are only of effects on the motion: a sensor effect pays alone or not at all.
    #[test]
    fn no_pair_holds_a_sensor_effect() {
        let reach = CommandReach {
            wheel_rad_s: 10.0,
            speed_m_s: 2.0,
            yaw_rate_rad_s: 1.0,
        };
        let index = |name: &str| REGISTRY.iter().position(|e| e.name() == name).expect(name);
        let c: Vec<Candidate> = [
            "controller_kinematics",
            "imu_yaw_rate_sign_flip",
            "body_lag",
            "dead_time_s",
        ]
        .iter()
        .map(|n| Candidate::of_effect(index(n), &reach))
        .collect();
        let names: Vec<String> = pairs_of(&c.iter().collect::<Vec<_>>())
            .into_iter()
            .map(|p| p.name)
            .collect();
        assert_eq!(
            names,
            [
                "controller_kinematics+body_lag",
                "controller_kinematics+dead_time_s",
                "body_lag+dead_time_s"
            ]
        );
    }

    /// A step whose 6 steady channels all have mean squared error `r` (floors 1, one window,
    /// no transient): its score is `r`, and a pooled score is the mean of the steps' `r`.
    fn step(r: f64) -> StepErrors {
        StepErrors {
            step: 0,
            steady_sq: [r; 6],
            n_steady: 1,
            transient_sq: [0.0; 4],
            n_transient: 0,
            pose_sq: [0.0; 2],
            n_windows: 0,
        }
    }

    fn unit_floor() -> NoiseFloor {
        NoiseFloor {
            steady: [1.0; 6],
            series: [1.0; 4],
            pose: [1.0; 2],
            steps_used: 0,
        }
    }

    #[test]
    fn bootstrap_se_matches_the_formula() {
        // Equal channels: the pooled score is the mean of the steps' r. `after` halves every
        // error, so each resample's reduction is mean(r) / 2 and its SE half that of a mean:
        // (s / √n) / 2, s the population standard deviation of r (values 1 and 3: s = 1).
        let before: Vec<StepErrors> = (0..50)
            .map(|i| step(if i % 2 == 0 { 1.0 } else { 3.0 }))
            .collect();
        let after: Vec<StepErrors> = (0..50)
            .map(|i| step(if i % 2 == 0 { 0.5 } else { 1.5 }))
            .collect();
        let floor = unit_floor();
        assert!((score(&before, &floor) - 2.0).abs() < 1e-12);
        let se = bootstrap_reduction_se(&before, &after, &floor, 4000, 1);
        let expected = 0.5 / 50f64.sqrt();
        assert!((se - expected).abs() < 0.1 * expected, "{se} vs {expected}");
        assert_eq!(bootstrap_reduction_se(&before, &before, &floor, 100, 0), 0.0);
        assert!(bootstrap_reduction_se(&before[..1], &after[..1], &floor, 100, 0).is_infinite());
    }

    #[test]
    fn candidates_follow_the_plant() {
        use crate::model::{KinematicFactory, SimFactory};
        let reach = CommandReach {
            wheel_rad_s: 10.0,
            speed_m_s: 3.0,
            yaw_rate_rad_s: 2.0,
        };
        let (k, left_out) = candidates_for(&KinematicFactory, &reach, None);
        assert_eq!(k.len(), 22);
        assert_eq!(
            left_out,
            [
                "motor_torque_speed",
                "speed_droop",
                "droop_recovery",
                "turning_resistance_scale",
                "suspension_torsion_m"
            ]
        );
        // The torque-speed line is not in the default catalogue: tried only when named.
        let (s, none) = candidates_for(&SimFactory::default(), &reach, None);
        assert_eq!((s.len(), none.len()), (24, 0));
        let named = ["motor_torque_speed".to_string()];
        let (m, _) = candidates_for(&SimFactory::default(), &reach, Some(&named));
        assert_eq!((m.len(), m[0].params.len()), (1, 2));
        let only = ["dead_time_s".to_string(), "motor_gain".to_string()];
        let (c, _) = candidates_for(&SimFactory::default(), &reach, Some(&only));
        let names: Vec<&str> = c.iter().map(|c| c.name.as_str()).collect();
        assert_eq!(names, ["dead_time_s", "motor_gain"]);
        assert_eq!(c[1].params.len(), 2);
        // Limits are searched below the reach, started mid-box.
        let (sat, _) = candidates_for(
            &SimFactory::default(),
            &reach,
            Some(&["wheel_speed_saturation_rad_s".into()]),
        );
        let p = sat[0].params[0];
        assert_eq!((p.lower, p.upper, p.start), (2.0, 10.0, 6.0));
    }
}
