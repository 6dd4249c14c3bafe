//! Replay: drive a [`Plant`] with the recorded commands of each step of a [`DriveLog`], each
//! step starting from the measured state at its first sample, and log the response with the
//! same step / window / k structure as the recording.

use super::model::{ModelParams, PlantFactory};
use crate::error::{Error, Result};
use crate::kinematics::{BodyVelocity, WheelSpeeds};
use crate::log::{DriveLog, Frame, LogMeta, Origin, Pose, Sample};
use crate::sim::Plant;
use rayon::prelude::*;

/// The samples of one completed step, in time order.
#[derive(Debug, Clone, Copy)]
pub struct StepSlice<'a> {
    /// Step index.
    pub step: u32,
    /// Its samples.
    pub samples: &'a [Sample],
}

/// Splits a log's samples into steps (they are stored ordered by step).
pub fn step_slices(log: &DriveLog) -> Vec<StepSlice<'_>> {
    log.samples
        .chunk_by(|a, b| a.step == b.step)
        .map(|s| StepSlice {
            step: s[0].step,
            samples: s,
        })
        .collect()
}

/// The measured state a replayed step starts from.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StepStart {
    /// Pose of the first sample.
    pub pose: Pose,
    /// Body velocity at the first sample: the source's reference estimate when it has one,
    /// else the pose difference over the first 0.25 s of the step, in the body frame.
    pub velocity: BodyVelocity,
    /// Encoder wheel speeds of the first sample.
    pub wheels: WheelSpeeds,
}

/// Estimates the state at the start of a step (see [`StepStart`]).
pub fn step_start(samples: &[Sample]) -> Result<StepStart> {
    let first = samples
        .first()
        .ok_or_else(|| Error::Analysis("empty step".into()))?;
    let velocity = match first.m.reference {
        Some(v) if v.is_finite() => v,
        _ => {
            // Forward difference inside the first window (poses restart at each window in
            // measured logs), over up to 5 samples.
            let end = samples
                .iter()
                .take(6)
                .take_while(|s| s.window == first.window)
                .last()
                .unwrap_or(first);
            let dt = end.t_in_step_s - first.t_in_step_s;
            if dt > 0.0 {
                let v = super::metrics::body_rate(&first.m.pose, &end.m.pose, dt);
                BodyVelocity::new(v[0], v[1], v[2])
            } else {
                BodyVelocity::default()
            }
        }
    };
    Ok(StepStart {
        pose: first.m.pose,
        velocity,
        wheels: first.m.enc,
    })
}

/// Replays one step on `plant`: reset to the measured start, then for every recorded sample
/// command, measure, advance to the next sample time (the protocol runner's order).
pub fn replay_step(plant: &mut dyn Plant, step: StepSlice<'_>, rate_hz: f64) -> Result<Vec<Sample>> {
    let start = step_start(step.samples)?;
    let wheels = plant.wheels_from_encoders(start.wheels);
    plant.reset(start.pose, start.velocity, wheels);
    let mut out = Vec::with_capacity(step.samples.len());
    for (i, s) in step.samples.iter().enumerate() {
        plant.command(s.m.cmd);
        let mut m = plant.measure();
        m.cmd = s.m.cmd;
        out.push(Sample { m, ..*s });
        let dt = match step.samples.get(i + 1) {
            Some(n) if n.t_in_step_s > s.t_in_step_s => n.t_in_step_s - s.t_in_step_s,
            _ => 1.0 / rate_hz,
        };
        plant.advance(dt).map_err(|e| match e {
            Error::Diverged { message, time_s, .. } => Error::Diverged {
                step: step.step,
                time_s,
                message,
            },
            e => e,
        })?;
    }
    Ok(out)
}

/// Replays the given steps in parallel, one fresh plant per step; results in input order.
pub fn replay_steps(
    steps: &[StepSlice<'_>],
    factory: &dyn PlantFactory,
    params: &ModelParams,
    rate_hz: f64,
) -> Result<Vec<Vec<Sample>>> {
    steps
        .par_iter()
        .map(|s| {
            let mut plant = factory.build(params)?;
            replay_step(plant.as_mut(), *s, rate_hz)
        })
        .collect()
}

/// Which steps to replay.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ReplayOptions {
    /// Only these steps (all when `None`).
    pub steps: Option<Vec<u32>>,
}

/// Replays a whole log (or some of its steps) on the plant `factory` builds from `params`;
/// the result is a [`DriveLog`] with the recording's structure and metadata, its origin marked
/// as a simulated replay. Fails on a step that does not exist or a plant that diverges.
pub fn replay_log(
    log: &DriveLog,
    factory: &dyn PlantFactory,
    params: &ModelParams,
    opts: &ReplayOptions,
) -> Result<DriveLog> {
    let all = step_slices(log);
    let chosen: Vec<StepSlice<'_>> = match &opts.steps {
        None => all,
        Some(want) => {
            let mut v = Vec::with_capacity(want.len());
            for w in want {
                let s = all.iter().find(|s| s.step == *w).ok_or_else(|| {
                    Error::Analysis(format!("replay: step {w} is not in log `{}`", log.meta.name))
                })?;
                v.push(*s);
            }
            v
        }
    };
    let replayed = replay_steps(&chosen, factory, params, log.meta.rate_hz)?;
    let frames: Vec<Frame> = replayed.iter().flatten().map(|s| s.to_frame()).collect();
    let meta = LogMeta {
        name: format!("{}_replay_{}", log.meta.name, factory.name()),
        origin: Origin::Simulated {
            seed: 0,
            robot_file: params.robot.name.clone(),
            terrain_file: params.terrain.name.clone(),
            // The model's effects are declared, not injected: they go in the description.
            sampler: format!(
                "replay of {} (effects: {})",
                log.meta.name,
                params
                    .effects
                    .iter()
                    .map(|(k, v)| format!("{k}={v}"))
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
            injected: Vec::new(),
        },
        ..log.meta.clone()
    };
    Ok(DriveLog::from_frames(meta, &frames))
}
