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
//! | `wheel_speed_scatter` | `scatter`: step-to-step against within-step wheel scatter | `√(σ_step² − f²)` |
//!
//! They leave the closed loop's pool ([`MEASURED`]): the search has its coordinates for the
//! effects the log cannot measure.

use drive_sim_analysis::pose_updates::PoseUpdates;
use drive_sim_analysis::Analysis;
use drive_sim_calibration::ModelParams;
use serde::{Deserialize, Serialize};

/// The effects a log measures (their registry names): never knobs of the closed loop.
pub const MEASURED: [&str; 2] = ["pose_updates", "wheel_speed_scatter"];

/// A step-level wheel offset smaller than this is not declared, rad/s: below the smallest
/// within-step scatter of the measured runs (ice, 0.11 rad/s), which the twin's own noise
/// gives.
const MIN_WHEEL_OFFSET_RAD_S: f64 = 0.05;

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

/// The values the choosing steps of `analyses` (one per log, one robot) measure; nothing for
/// an effect the logs do not show.
pub fn measure(analyses: &[&Analysis]) -> Vec<MeasuredValue> {
    let mut out = Vec::new();
    let updates: Vec<PoseUpdates> = analyses.iter().filter_map(|a| a.pose_updates).collect();
    if let Some(p) = PoseUpdates::pooled(&updates).filter(|p| !p.every_sample()) {
        let from = format!(
            "{} intervals between pose changes on the logs: mean {:.3} s, sd {:.3} s ({:.0} % of the samples repeat the pose before)",
            p.intervals,
            p.mean_interval_s,
            p.interval_sd_s,
            100.0 * p.held_share
        );
        for (name, value) in [
            ("pose_update_period_s", p.period_s),
            ("pose_update_jitter_s", p.jitter_s),
        ] {
            out.push(MeasuredValue {
                name: name.into(),
                value,
                unit: "s".into(),
                from: from.clone(),
            });
        }
    }
    // Each log's step-level offset, weighted by its pairs of neighbouring steps.
    let offsets: Vec<(f64, usize)> = analyses
        .iter()
        .filter_map(|a| Some((a.step_scatter.step_offset_rad_s()?, a.step_scatter.pairs)))
        .collect();
    let pairs: usize = offsets.iter().map(|o| o.1).sum();
    if pairs > 0 {
        let s = (offsets.iter().map(|(s, n)| s * s * *n as f64).sum::<f64>() / pairs as f64).sqrt();
        if s >= MIN_WHEEL_OFFSET_RAD_S {
            let within: Vec<String> = analyses
                .iter()
                .map(|a| {
                    format!(
                        "{}: step to step {}, within a step {}",
                        a.dataset,
                        a.step_scatter
                            .wheel_rad_s
                            .map_or("-".into(), |v| format!("{v:.3}")),
                        a.step_scatter
                            .within_step_rad_s
                            .map_or("-".into(), |v| format!("{v:.3}"))
                    )
                })
                .collect();
            out.push(MeasuredValue {
                name: "wheel_speed_scatter_rad_s".into(),
                value: s,
                unit: "rad/s".into(),
                from: format!(
                    "the steady wheels' step scatter the within-step scatter does not explain, √(step² − within²) over {pairs} pairs of neighbouring steps (rad/s per wheel; {})",
                    within.join("; ")
                ),
            });
        }
    }
    out
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
