//! What a log measures directly: the random effects, declared on the twin from the choosing
//! steps' statistics before the closed loop, not searched by it.
//!
//! Why: a random effect that is zero-mean (a pose read late or early, a wheel loop that settles
//! off its target by a different amount each step) barely moves the medians and the smoothed
//! maps a loss compares; a search weighs it against knobs that move them, and a rule that
//! takes the largest gains first leaves it out. Yet the robot's runs carry it, and a twin
//! without it is more predictable than the robot: its steps the robot drives well land on
//! their commands, where the robot's scatter and fold into larger ρ. Each of these effects has a
//! statistic of its own on the log that gives its size, by moments, with no run of the model:
//!
//! | effect | statistic (`drive_sim_analysis`) | value |
//! |---|---|---|
//! | `pose_updates` | `pose_updates`: intervals between pose changes | period and jitter of the intervals |
//! | `wheel_speed_scatter` | `scatter`: the wheels' step scatter, the run's and the model's | `√(σ_run² − σ_model²)` |
//!
//! The wheels' offset is what the model's own step scatter lacks: a deterministic model already
//! scatters between neighbouring steps (their commands differ by up to 1 rad/s, their histories
//! differ; the Husky's calibrated twin 0.18 rad/s per wheel against its run's 0.27), so the
//! offset is measured against one closed-loop run of the calibrated model drawn as the run was,
//! and the two add in quadrature. They leave the closed loop's pool ([`MEASURED`]): the search
//! has its coordinates for the effects the log cannot measure.

use drive_sim_analysis::pose_updates::PoseUpdates;
use drive_sim_analysis::Analysis;
use drive_sim_calibration::ModelParams;
use drive_sim_compare::tune::twin_run_matched;
use drive_sim_compare::{analysis_of, PreparedReal};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// The effects a log measures (their registry names): never knobs of the closed loop.
pub const MEASURED: [&str; 2] = ["pose_updates", "wheel_speed_scatter"];

/// A step-level wheel offset smaller than this is not declared, rad/s: below the smallest
/// within-step scatter of the measured runs (ice, 0.11 rad/s), which the twin's own noise
/// gives.
pub const MIN_WHEEL_OFFSET_RAD_S: f64 = 0.05;

/// One value declared from the logs (`twin.json` → `*.pass.measured`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MeasuredValue {
    /// The effect parameter's key.
    pub name: String,
    /// Its value.
    pub value: f64,
    /// Its unit.
    pub unit: String,
    /// What on the logs gives it.
    pub from: String,
}

/// Measures the random effects on each ground's choosing steps (`real`, as compare prepared
/// them, `steps[i]` DRIVE steps each) and declares them on every model of `models` (one per
/// ground, one robot): first the pose's updates, then the wheels' offset against one
/// closed-loop run of each ground's model, seeded `seed`, drawn as its steps were and analysed
/// as compare analyses a run. Returns what it declared.
pub fn declare_measured(
    models: &mut [ModelParams],
    real: &[PreparedReal],
    steps: &[u32],
    seed: u64,
) -> crate::Result<Vec<MeasuredValue>> {
    let runs: Vec<&Analysis> = real.iter().map(PreparedReal::analysis).collect();
    let mut measured = pose_updates(&runs);
    declare(models, &measured)?;
    let own: Vec<Analysis> = models
        .par_iter()
        .zip(real)
        .zip(steps)
        .map(|((model, real), &n)| Ok(analysis_of(&twin_run_matched(model, real.commands(), n, seed)?)?))
        .collect::<crate::Result<_>>()?;
    if let Some(offset) = wheel_offset(&runs, &own.iter().collect::<Vec<_>>()) {
        declare(models, std::slice::from_ref(&offset))?;
        measured.push(offset);
    }
    Ok(measured)
}

/// The pose's update intervals the choosing steps of `analyses` (one per log, one robot)
/// measure, pooled; nothing when the pose changes at every sample.
pub fn pose_updates(analyses: &[&Analysis]) -> Vec<MeasuredValue> {
    let updates: Vec<PoseUpdates> = analyses.iter().filter_map(|a| a.pose_updates).collect();
    let Some(p) = PoseUpdates::pooled(&updates).filter(|p| !p.every_sample()) else {
        return Vec::new();
    };
    let from = format!(
        "{} intervals between pose changes on the logs: mean {:.3} s, sd {:.3} s ({:.0} % of the samples repeat the pose before)",
        p.intervals,
        p.mean_interval_s,
        p.interval_sd_s,
        100.0 * p.held_share
    );
    [
        ("pose_update_period_s", p.period_s),
        ("pose_update_jitter_s", p.jitter_s),
    ]
    .into_iter()
    .map(|(name, value)| MeasuredValue {
        name: name.into(),
        value,
        unit: "s".into(),
        from: from.clone(),
    })
    .collect()
}

/// The wheels' step-level offset that the model lacks: for each log, the run's step scatter
/// squared less the model's (its run drawn as the log was, `models[i]` beside `runs[i]`),
/// pooled weighted by the run's pairs of neighbouring steps; `None` below
/// [`MIN_WHEEL_OFFSET_RAD_S`] or without an estimate (too few pairs on either side).
pub fn wheel_offset(runs: &[&Analysis], models: &[&Analysis]) -> Option<MeasuredValue> {
    let mut parts = Vec::new();
    let (mut sum, mut pairs) = (0.0, 0usize);
    for (run, model) in runs.iter().zip(models) {
        let (Some(r), Some(m)) = (run.step_scatter.wheel_rad_s, model.step_scatter.wheel_rad_s) else {
            continue;
        };
        let n = run.step_scatter.pairs;
        sum += (r * r - m * m) * n as f64;
        pairs += n;
        parts.push(format!(
            "{}: {r:.3} rad/s over {n} pairs, the model's {m:.3} over {}",
            run.dataset, model.step_scatter.pairs
        ));
    }
    if pairs == 0 {
        return None;
    }
    let s = (sum / pairs as f64).max(0.0).sqrt();
    (s >= MIN_WHEEL_OFFSET_RAD_S).then(|| MeasuredValue {
        name: "wheel_speed_scatter_rad_s".into(),
        value: s,
        unit: "rad/s".into(),
        from: format!(
            "the steady wheels' step scatter the calibrated model's own does not give, √(run² − model²) per wheel ({})",
            parts.join("; ")
        ),
    })
}

/// `models` with `values` declared (every model: they are the robot's).
pub fn declare(models: &mut [ModelParams], values: &[MeasuredValue]) -> crate::Result<()> {
    for m in models {
        for v in values {
            m.effects.set(&v.name, v.value)?;
        }
    }
    Ok(())
}
