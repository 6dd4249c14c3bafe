//! Candidate effects and the evidence for each: fit its parameter(s) alone on the training
//! steps, then measure the error reduction on the held-out steps, with a bootstrap standard
//! error over held-out steps. Ranked by held-out reduction.

use super::fit::{fit, mean_score, FitOptions, FittedParam, StepSet};
use super::metrics::{NoiseFloor, StepErrors};
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

/// Search boxes of the known effects. `max_cmd_rad_s` is the largest commanded wheel speed of
/// the log (a saturation is searched below it). Effects the plant implements but that have no
/// known box are returned by name in the second list (reported as not evaluated).
pub fn default_candidates(
    effect_names: &[String],
    max_cmd_rad_s: f64,
) -> (Vec<EffectCandidate>, Vec<String>) {
    let has = |n: &str| effect_names.iter().any(|e| e == n);
    let one = |n: &str, lo: f64, hi: f64, start: f64| EffectCandidate {
        name: n.to_string(),
        params: vec![ParamSpec::new(format!("effect.{n}"), lo, hi).with_start(start)],
    };
    let mut out = Vec::new();
    let mut known: Vec<&str> = Vec::new();
    let wmax = max_cmd_rad_s.max(1e-3);
    let singles: [(&str, f64, f64, f64); 11] = [
        ("wheel_speed_saturation_rad_s", 0.2 * wmax, wmax, wmax),
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
    let unknown = effect_names
        .iter()
        .filter(|n| !known.contains(&n.as_str()))
        .cloned()
        .collect();
    (out, unknown)
}

/// Standard error of the mean of `diffs` by bootstrap over its entries (seeded).
pub fn bootstrap_se(diffs: &[f64], samples: usize, seed: u64) -> f64 {
    let n = diffs.len();
    if n < 2 || samples < 2 {
        return f64::INFINITY;
    }
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let means: Vec<f64> = (0..samples)
        .map(|_| (0..n).map(|_| diffs[rng.random_range(0..n)]).sum::<f64>() / n as f64)
        .collect();
    let m = means.iter().sum::<f64>() / samples as f64;
    (means.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (samples - 1) as f64).sqrt()
}

/// Paired per-step score differences `before - after` (positive: `after` is better).
pub fn paired_diffs(before: &[StepErrors], after: &[StepErrors], floor: &NoiseFloor) -> Vec<f64> {
    before
        .iter()
        .zip(after)
        .map(|(b, a)| b.score(floor) - a.score(floor))
        .collect()
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
    /// Its fitted parameters (fitted alone, everything else fixed).
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

/// Tries each candidate alone on top of `current`, ranks them by held-out reduction (best
/// first), and returns each with the model it produced.
#[allow(clippy::too_many_arguments)]
pub fn evaluate_candidates(
    train: &StepSet<'_>,
    test: &StepSet<'_>,
    factory: &dyn PlantFactory,
    current: &ModelParams,
    floor: &NoiseFloor,
    candidates: &[EffectCandidate],
    fit_opts: &FitOptions,
    rule: &SelectionRule,
) -> Result<Vec<(CandidateEvidence, ModelParams)>> {
    let before = test.errors(factory, current)?;
    let heldout_before = mean_score(&before, floor);
    let mut out = Vec::new();
    for (i, c) in candidates.iter().enumerate() {
        let (model, res) = fit(train, factory, current, &c.params, floor, fit_opts)?;
        let after = test.errors(factory, &model)?;
        let heldout_after = mean_score(&after, floor);
        let diffs = paired_diffs(&before, &after, floor);
        let reduction = heldout_before - heldout_after;
        let se = bootstrap_se(&diffs, rule.bootstrap_samples, rule.seed.wrapping_add(i as u64));
        let excess = heldout_before - 1.0;
        out.push((
            CandidateEvidence {
                effect: c.name.clone(),
                params: res.params,
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

    #[test]
    fn bootstrap_se_matches_the_formula() {
        // SE of a mean of n iid values ≈ s / √n (population s with bootstrap).
        let d: Vec<f64> = (0..50).map(|i| if i % 2 == 0 { 1.0 } else { -1.0 }).collect();
        let se = bootstrap_se(&d, 4000, 1);
        let expected = 1.0 / 50f64.sqrt();
        assert!((se - expected).abs() < 0.1 * expected, "{se} vs {expected}");
        assert!(bootstrap_se(&[1.0], 100, 0).is_infinite());
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
        let (c, unknown) = default_candidates(&names, 10.0);
        let n: Vec<&str> = c.iter().map(|c| c.name.as_str()).collect();
        assert_eq!(n, ["dead_time_s", "motor_gain"]);
        assert_eq!(c[1].params.len(), 2);
        assert_eq!(unknown, ["suspension_stiffness"]);
    }
}
