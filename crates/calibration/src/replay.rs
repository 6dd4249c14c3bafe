//! Replay: drive a [`Plant`] with the recorded commands of each step of a [`DriveLog`], each
//! step starting from the measured state at its first sample, and log the response with the
//! same step / window / k structure as the recording.
//!
//! Replays are what calibration spends its time on, so they are cheap: one plant (one rapier
//! world) is built per chunk of steps and reset between them (a reset plant replays exactly
//! as a new one; tested), chunks run in parallel, and the chunking is fixed so the result does
//! not depend on the thread count.

use super::model::{ModelParams, PlantFactory};
use super::steps::{step_slices, step_start_in, StepSlice, StepStart};
use crate::error::{Error, Result};
use drive_sim_log::{DriveLog, Frame, LogMeta, Origin, Sample};
use drive_sim_sim::Plant;
use rayon::prelude::*;
use std::sync::atomic::{AtomicU64, Ordering};

/// Steps replayed on one plant before the next chunk gets its own.
const STEPS_PER_PLANT: usize = 8;

/// Steps replayed and plants built since the process started (for the per-stage counters).
static STEPS_REPLAYED: AtomicU64 = AtomicU64::new(0);
static PLANTS_BUILT: AtomicU64 = AtomicU64::new(0);

/// Replay counters: steps replayed and plants (worlds) built so far in this process.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ReplayCounters {
    /// Steps replayed.
    pub steps: u64,
    /// Plants built.
    pub plants: u64,
}

impl ReplayCounters {
    /// The counters now.
    pub fn now() -> Self {
        Self {
            steps: STEPS_REPLAYED.load(Ordering::Relaxed),
            plants: PLANTS_BUILT.load(Ordering::Relaxed),
        }
    }

    /// What happened between `earlier` and `self`.
    pub fn since(self, earlier: Self) -> Self {
        Self {
            steps: self.steps - earlier.steps,
            plants: self.plants - earlier.plants,
        }
    }
}

/// Replays one step on `plant` from `start`: reset, then for every recorded sample command,
/// measure, advance to the next sample time (the protocol runner's order).
pub fn replay_step(
    plant: &mut dyn Plant,
    step: StepSlice<'_>,
    start: &StepStart,
    rate_hz: f64,
) -> Result<Vec<Sample>> {
    let wheels = plant.wheels_from_encoders(start.wheels);
    plant.reset(start.pose, start.velocity, wheels);
    plant.begin_step(start.context(step.step));
    STEPS_REPLAYED.fetch_add(1, Ordering::Relaxed);
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
            drive_sim_model::Error::Diverged { message, time_s, .. } => drive_sim_model::Error::Diverged {
                step: step.step,
                time_s,
                message,
            },
            e => e,
        })?;
    }
    Ok(out)
}

/// Replays the given steps (with their starts, same order) and hands each replay to `f`;
/// results in input order. One plant per chunk of `STEPS_PER_PLANT` (8) steps, chunks in
/// parallel.
pub fn replay_map<T: Send>(
    steps: &[StepSlice<'_>],
    starts: &[StepStart],
    factory: &dyn PlantFactory,
    params: &ModelParams,
    rate_hz: f64,
    f: impl Fn(usize, Vec<Sample>) -> Result<T> + Sync,
) -> Result<Vec<T>> {
    if steps.len() != starts.len() {
        return Err(Error::StartStates {
            steps: steps.len(),
            starts: starts.len(),
        });
    }
    let chunks: Vec<Vec<T>> = (0..steps.len())
        .collect::<Vec<_>>()
        .par_chunks(STEPS_PER_PLANT)
        .map(|idx| {
            let mut plant = factory.build(params)?;
            PLANTS_BUILT.fetch_add(1, Ordering::Relaxed);
            idx.iter()
                .map(|&i| f(i, replay_step(plant.as_mut(), steps[i], &starts[i], rate_hz)?))
                .collect::<Result<Vec<T>>>()
        })
        .collect::<Result<_>>()?;
    Ok(chunks.into_iter().flatten().collect())
}

/// Replays the given steps; results in input order.
pub fn replay_steps(
    steps: &[StepSlice<'_>],
    factory: &dyn PlantFactory,
    params: &ModelParams,
    rate_hz: f64,
) -> Result<Vec<Vec<Sample>>> {
    let starts = steps
        .iter()
        .map(|s| step_start_in(steps, *s, |_| true))
        .collect::<Result<Vec<_>>>()?;
    replay_map(steps, &starts, factory, params, rate_hz, |_, s| Ok(s))
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
                let s = all
                    .iter()
                    .find(|s| s.step == *w)
                    .ok_or_else(|| Error::ReplayStepNotInLog {
                        step: *w,
                        log: log.meta.name.clone(),
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
        origin: Origin::Replayed {
            of: log.meta.name.clone(),
            model: factory.name(),
            robot_file: params.robot.name.clone(),
            terrain_file: params.terrain.name.clone(),
            effects: params
                .effects
                .declared()
                .iter()
                .map(|(k, v)| format!("{k}={v}"))
                .collect(),
        },
        ..log.meta.clone()
    };
    Ok(DriveLog::from_frames(meta, &frames))
}
