//! Candidate effects and the evidence for each: fit its parameter(s) on the training steps
//! (with the terrain / robot parameters refit beside them), then measure the error reduction on
//! the held-out steps, with a bootstrap standard error over held-out steps. Ranked by held-out
//! reduction.

use super::fit::{fit, FitOptions, FittedParam, StepSet};
use super::metrics::{score, NoiseFloor, StepErrors};
use super::model::{ModelParams, ParamSpec, PlantFactory};
use crate::error::Result;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

/// An effect that may be added to the model, with the parameters fitted when it is tried.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct EffectCandidate {
    /// Name in reports (an `Effects` name, or a group such as `motor_gain`).
    pub name: String,
    /// Its parameters (`effect.<name>`), search boxes and neutral start values.
    pub params: Vec<ParamSpec>,
}

/// How far a log's commands reach: limits are searched below these.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct CommandReach {
    /// Largest commanded wheel speed, rad/s.
    pub wheel_rad_s: f64,
    /// Largest commanded forward speed (nominal geometry), m/s.
    pub speed_m_s: f64,
    /// Largest commanded yaw rate (nominal geometry), rad/s.
    pub yaw_rate_rad_s: f64,
}

/// Search boxes of the known effects, limits below what the log commands (`reach`). Effects
/// the plant implements but that have no known box are returned by name in the second list
/// (reported as not evaluated).
pub fn default_candidates(
    effect_names: &[String],
    reach: &CommandReach,
) -> (Vec<EffectCandidate>, Vec<String>) {
    let has = |n: &str| effect_names.iter().any(|e| e == n);
    let one = |n: &str, lo: f64, hi: f64, start: f64| EffectCandidate {
        name: n.to_string(),
        params: vec![ParamSpec::new(format!("effect.{n}"), lo, hi).with_start(start)],
    };
    let mut out = Vec::new();
    let mut known: Vec<&str> = Vec::new();
    let wmax = reach.wheel_rad_s.max(1e-3);
    let vmax = reach.speed_m_s.max(1e-3);
    let yaw_max = reach.yaw_rate_rad_s.max(1e-3);
    // Limits start mid-box: near the largest command the cost is flat (few commands reach
    // there), and a simplex started in a flat region stops at once.
    let limit = |n: &'static str, lo: f64, hi: f64| (n, lo, hi, (lo + hi) / 2.0);
    let singles: [(&str, f64, f64, f64); 14] = [
        limit("wheel_speed_saturation_rad_s", 0.2 * wmax, wmax),
        limit("controller_wheel_limit_rad_s", 0.2 * wmax, wmax),
        // A controller's body-space limits can sit far below what a protocol commands (a
        // Husky commanded at 8.7 rad/s turns at under 2): searched down to a tenth.
        limit("command_speed_limit_m_s", 0.1 * vmax, vmax),
        limit("command_yaw_rate_limit_rad_s", 0.1 * yaw_max, yaw_max),
        ("wheel_radius_scale", 0.7, 1.3, 1.0),
        ("dead_time_s", 0.0, 0.6, 0.0),
        ("time_constant_scale", 0.2, 5.0, 1.0),
        ("turning_resistance_scale", 0.2, 5.0, 1.0),
        // Tyre lateral relaxation length: from off to about two tyre diameters.
        ("suspension_torsion_m", 0.0, 1.2, 0.0),
        ("imu_yaw_rate_scale", 0.5, 1.5, 1.0),
        ("imu_yaw_rate_bias_rad_s", -0.2, 0.2, 0.0),
        ("pose_latency_s", 0.0, 0.5, 0.0),
        ("encoder_scale", 0.7, 1.3, 1.0),
        ("imu_yaw_rate_sign_flip", 0.0, 1.0, 0.0),
    ];
    for (n, lo, hi, start) in singles {
        known.push(n);
        if has(n) {
            let mut c = one(n, lo, hi, start);
            if n == "imu_yaw_rate_sign_flip" {
                c.params[0] = c.params[0].clone().discrete();
            }
            out.push(c);
        }
    }
    // One side's motor weaker than the other: both gains together (2-D).
    known.extend(["motor_gain_left", "motor_gain_right"]);
    if has("motor_gain_left") && has("motor_gain_right") {
        out.push(EffectCandidate {
            name: "motor_gain".into(),
            params: vec![
                ParamSpec::new("effect.motor_gain_left", 0.5, 1.3).with_start(1.0),
                ParamSpec::new("effect.motor_gain_right", 0.5, 1.3).with_start(1.0),
            ],
        });
    }
    // The controller's own kinematics: speed and turning gains together (2-D).
    known.extend(["controller_radius_scale", "controller_baseline_scale"]);
    if has("controller_radius_scale") && has("controller_baseline_scale") {
        out.push(EffectCandidate {
            name: "controller_kinematics".into(),
            params: vec![
                ParamSpec::new("effect.controller_radius_scale", 0.4, 2.0).with_start(1.0),
                ParamSpec::new("effect.controller_baseline_scale", 0.3, 3.0).with_start(1.0),
            ],
        });
    }
    let unknown = effect_names
        .iter()
        .filter(|n| !known.contains(&n.as_str()))
        .cloned()
        .collect();
    (out, unknown)
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

/// When an improvement counts: beyond `k_se` bootstrap standard errors of the held-out score
/// difference and beyond `min_rel` of the held-out score before (a complexity penalty: an extra
/// parameter must buy a real, not a within-noise, reduction).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct SelectionRule {
    /// Required reduction in bootstrap standard errors.
    pub k_se: f64,
    /// Required relative reduction of the held-out score.
    pub min_rel: f64,
    /// Bootstrap resamples.
    pub bootstrap_samples: usize,
    /// Bootstrap seed.
    pub seed: u64,
}

impl Default for SelectionRule {
    fn default() -> Self {
        Self {
            k_se: 2.0,
            min_rel: 0.02,
            bootstrap_samples: 1000,
            seed: 0,
        }
    }
}

/// The evidence for one candidate effect.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CandidateEvidence {
    /// Candidate name.
    pub effect: String,
    /// Its fitted parameters (fitted with the terrain / robot parameters refit).
    pub params: Vec<FittedParam>,
    /// Training score before and after fitting it.
    pub train_score_before: f64,
    /// Training score after.
    pub train_score_after: f64,
    /// Held-out score without it.
    pub heldout_before: f64,
    /// Held-out score with it.
    pub heldout_after: f64,
    /// `heldout_before - heldout_after`.
    pub reduction: f64,
    /// Bootstrap standard error of the reduction (over held-out steps).
    pub reduction_se: f64,
    /// Share of the held-out residual above the noise floor it explains:
    /// `reduction / (heldout_before - 1)`, 1 being the floor's score.
    pub share: f64,
    /// Passes the [`SelectionRule`].
    pub significant: bool,
    /// Optimizer converged.
    pub converged: bool,
    /// Optimizer status.
    pub fit_status: String,
}

/// Tries each candidate on top of `current`, its parameters fitted together with the
/// `refit` parameters (the terrain / robot ones), ranks them by held-out reduction (best
/// first), and returns each with the model it produced. With `refit_from`, each candidate is
/// also fitted starting from that model's values of the `refit` parameters (the declared
/// ones), and the better fit on the training steps is kept.
///
/// Why refit: the terrain fit has already absorbed what it could of a missing effect (a
/// smaller wheel radius into a wider baseline, say); fitting the effect alone on top of that
/// compensation would find no gain, while the nested comparison (terrain vs terrain + effect,
/// both fitted) measures what the effect adds.
#[allow(clippy::too_many_arguments)]
pub fn evaluate_candidates(
    train: &StepSet<'_>,
    test: &StepSet<'_>,
    factory: &dyn PlantFactory,
    current: &ModelParams,
    refit: &[ParamSpec],
    refit_from: Option<&ModelParams>,
    floor: &NoiseFloor,
    candidates: &[EffectCandidate],
    fit_opts: &FitOptions,
    rule: &SelectionRule,
) -> Result<Vec<(CandidateEvidence, ModelParams)>> {
    let before = test.errors(factory, current)?;
    let heldout_before = score(&before, floor);
    let mut out = Vec::new();
    for (i, c) in candidates.iter().enumerate() {
        let specs: Vec<ParamSpec> = c.params.iter().chain(refit).cloned().collect();
        let (mut model, mut res) = fit(train, factory, current, &specs, floor, fit_opts)?;
        if let Some(alt) = refit_from {
            // Also from the declared values of the refit parameters: the compensation the
            // terrain fit found (a wide baseline standing in for a yaw-rate limit) can be a
            // valley the simplex does not leave. Keep the better end on the training steps.
            let mut start = current.clone();
            for p in refit {
                if let Some(v) = alt.get(&p.name)? {
                    start.set(&p.name, v)?;
                }
            }
            let (m2, mut r2) = fit(train, factory, &start, &specs, floor, fit_opts)?;
            r2.evaluations += res.evaluations;
            if r2.score < res.score {
                r2.initial_score = res.initial_score;
                (model, res) = (m2, r2);
            } else {
                res.evaluations = r2.evaluations;
            }
        }
        let after = test.errors(factory, &model)?;
        let heldout_after = score(&after, floor);
        let reduction = heldout_before - heldout_after;
        let se = bootstrap_reduction_se(
            &before,
            &after,
            floor,
            rule.bootstrap_samples,
            rule.seed.wrapping_add(i as u64),
        );
        let excess = heldout_before - 1.0;
        out.push((
            CandidateEvidence {
                effect: c.name.clone(),
                params: res
                    .params
                    .into_iter()
                    .filter(|p| c.params.iter().any(|s| s.name == p.name))
                    .collect(),
                train_score_before: res.initial_score,
                train_score_after: res.score,
                heldout_before,
                heldout_after,
                reduction,
                reduction_se: se,
                share: if excess > 1e-9 { reduction / excess } else { 0.0 },
                significant: reduction > rule.k_se * se
                    && reduction > rule.min_rel * heldout_before
                    && res.score < res.initial_score,
                converged: res.converged,
                fit_status: res.status,
            },
            model,
        ));
    }
    out.sort_by(|a, b| b.0.reduction.total_cmp(&a.0.reduction));
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

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
        let names: Vec<String> = [
            "dead_time_s",
            "motor_gain_left",
            "motor_gain_right",
            "suspension_stiffness",
        ]
        .iter()
        .map(|s| s.to_string())
        .collect();
        let reach = CommandReach {
            wheel_rad_s: 10.0,
            speed_m_s: 3.0,
            yaw_rate_rad_s: 2.0,
        };
        let (c, unknown) = default_candidates(&names, &reach);
        let n: Vec<&str> = c.iter().map(|c| c.name.as_str()).collect();
        assert_eq!(n, ["dead_time_s", "motor_gain"]);
        assert_eq!(c[1].params.len(), 2);
        assert_eq!(unknown, ["suspension_stiffness"]);
    }
}
